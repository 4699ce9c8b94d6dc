"""Every module of ``service`` and ``schemas`` declares its public names, and they exist."""

from __future__ import annotations

import ast
import importlib
import pkgutil
from pathlib import Path

import pytest

import schemas
import service

MODULES = [
    info.name
    for package in (service, schemas)
    for info in pkgutil.walk_packages(package.__path__, prefix=f"{package.__name__}.")
]


@pytest.mark.parametrize("name", ["service", "schemas", *MODULES])
def test_module_declares_existing_public_names(name: str) -> None:
    module = importlib.import_module(name)
    assert module.__doc__, f"{name} has no docstring"
    names = module.__dict__.get("__all__")
    assert names is not None, f"{name} has no __all__"
    assert all(hasattr(module, n) for n in names)


def test_schemas_never_import_the_planner() -> None:
    for name in MODULES:
        if name.startswith("schemas"):
            path = importlib.import_module(name).__file__
            assert path is not None
            tree = ast.parse(Path(path).read_text(encoding="utf-8"))
            for node in ast.walk(tree):
                if isinstance(node, ast.Import):
                    assert not any(a.name.split(".")[0] == "planner" for a in node.names)
                elif isinstance(node, ast.ImportFrom):
                    assert (node.module or "").split(".")[0] not in ("planner", "service")

"""Every module of ``service`` and ``schemas`` declares its public names, and they exist."""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
import subprocess
import sys
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


def test_importing_service_builds_no_app() -> None:
    code = "import sys, service; print('service.main' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _project_imports() -> dict[str, set[str]]:
    """Each project module and the project modules it imports (anywhere in its body)."""
    root = Path(service.__file__).parents[1]
    graph: dict[str, set[str]] = {}
    for package in ("planner", "service", "schemas"):
        for path in (root / package).rglob("*.py"):
            parts = path.relative_to(root).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found: set[str] = set()
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Import):
                    found.update(alias.name for alias in node.names)
                elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                    # ``from planner.analysis import _kernels`` imports a module
                    for alias in node.names:
                        sub = f"{node.module}.{alias.name}"
                        found.add(sub if _is_module(sub) else node.module)
            graph[name] = found
    return {name: {m for m in found if m in graph and m != name} for name, found in graph.items()}


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


def test_no_two_project_modules_import_each_other() -> None:
    graph = _project_imports()
    assert "service.stores.redis" in graph["service.stores"]  # the graph sees the project
    pairs = sorted(
        (a, b) for a, found in graph.items() for b in found if a < b and a in graph.get(b, set())
    )
    assert pairs == []

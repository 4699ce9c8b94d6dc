"""The public surface: ``__all__`` names what exists, and layers point one way."""

from __future__ import annotations

import ast
from pathlib import Path

import planner


def test_all_names_exist() -> None:
    for name in planner.__all__:
        assert hasattr(planner, name), name
    assert sorted(planner.__all__) == sorted(set(planner.__all__))


def test_planner_imports_no_web_code() -> None:
    root = Path(planner.__file__).parent
    for path in root.rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            for name in names:
                top = name.split(".")[0]
                assert top not in {"fastapi", "pydantic", "service", "schemas", "starlette"}, (
                    f"{path.name} imports {name}"
                )


def test_planner_never_reads_the_environment() -> None:
    root = Path(planner.__file__).parent
    for path in root.rglob("*.py"):
        assert "os.environ" not in path.read_text(), path.name

"""The public surface: ``__all__`` names what exists, and layers point one way."""

from __future__ import annotations

import ast
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

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


GRID = np.zeros((4, 5), dtype=np.uint8)


def _outside_calls() -> list[tuple[str, Callable[[], object]]]:
    a = planner.analyse(GRID)
    wave = planner.goal_wave(a, [3, 4])
    p = planner.plan(GRID, [0, 0], [3, 4])
    return [
        ("reaches", lambda: planner.reaches(wave, a, [-1, 0])),
        ("reaches", lambda: planner.reaches(wave, a, (0, 5))),
        ("plan start", lambda: planner.plan(GRID, [4, 0], [3, 4])),
        ("plan goal", lambda: planner.plan(GRID, [0, 0], [0, -1])),
        ("goal_wave", lambda: planner.goal_wave(a, [-1, -1])),
        ("Session.step position", lambda: planner.Session(p).step([], position=[0, 9])),
        ("Session.step obstacles", lambda: planner.Session(p).step([[-1, 2]])),
        ("simulate", lambda: planner.simulate(GRID, [0, 0], [9, 9])),
        ("render_plan", lambda: planner.render_plan(p, trajectory=[[0, 0], [4, 4]])),
        ("render_plan dynamic", lambda: planner.render_plan(p, dynamic_obstacles=[[0, -3]])),
    ]


@pytest.mark.parametrize("case", range(len(_outside_calls())))
def test_every_public_function_refuses_a_cell_outside_the_map(case: int) -> None:
    name, call = _outside_calls()[case]
    with pytest.raises(planner.InvalidInput, match="outside the 4 x 5 map") as info:
        call()
    assert info.value.field, f"{name}: the error names no field"

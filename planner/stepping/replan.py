"""A stepping robot's replan: the cheapest way from its cell to the plan's goal round the
dynamic obstacles (and their margin), over the plan's grid or the unsealed one."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.analysis.cells import BLOCKED_CELL
from planner.errors import InvalidInput
from planner.maps.grids import as_cell
from planner.params import PARAMETER_RANGES
from planner.plans.detour import detour_cells
from planner.plans.moves import OPEN_UNSEALED
from planner.plans.planning import Plan
from planner.stepping.obstacles import obstacle_cells

__all__ = ["detour", "unsealed_detour"]


def detour(
    plan: Plan,
    cell: Any,
    dynamic_obstacles: Any = (),
    *,
    margin: int | None = None,
    narrow: bool = False,
) -> npt.NDArray[np.int64]:
    """The replan a stepping robot makes: the cheapest way (length + clean) from ``cell`` to the
    plan's goal with every cell within ``margin`` (default: the plan's ``dynamic_margin``) of a
    dynamic obstacle blocked, over the plan's grid or, with ``narrow``, the unsealed one.

    Returns the ``(n, 2)`` cells after ``cell`` up to the goal; no rows when there is no way.

    >>> from planner import plan
    >>> p = plan([[0, 0, 0], [0, 0, 0], [0, 0, 0]], [0, 0], [0, 2], preset="shortest")
    >>> detour(p, [0, 0], [[0, 1]], margin=0).tolist()   # round it, cutting no corner of it
    [[1, 0], [1, 1], [1, 2], [0, 2]]
    >>> detour(p, [0, 0], [[0, 1]], margin=1).tolist()
    []
    """
    a, wave, params = plan.analysis, plan.wave, plan.params
    r, c = as_cell(cell, a.shape, name="cell")
    if a.state[r, c] == BLOCKED_CELL:
        raise InvalidInput(f"cell [{r}, {c}] is on an obstacle", field="cell")
    obstacles = obstacle_cells(dynamic_obstacles, a.shape)
    if margin is None:
        margin = params.dynamic_margin
    low, high = PARAMETER_RANGES["dynamic_margin"]
    if isinstance(margin, bool) or not isinstance(margin, int) or not low <= margin <= high:
        msg = f"margin must be an integer in [{low}, {high}]; got {margin!r}"
        raise InvalidInput(msg, field="margin")
    W = a.shape[1]
    if not narrow or wave.narrow or not a.sealed:  # over the wave's grid (a resumable one's own)
        cells = wave.detour(r * W + c, obstacles, a.clean, margin)
    else:
        goal = plan.goal[0] * W + plan.goal[1]
        cells = unsealed_detour(a, r * W + c, goal, obstacles, margin, params.diagonal_cost)
    out: npt.NDArray[np.int64] = np.stack(np.divmod(cells, W), axis=1).reshape(-1, 2)
    return out


def unsealed_detour(
    a: Analysis,
    start: int,
    goal: int,
    obstacles: npt.NDArray[np.int64],
    margin: int,
    diagonal_cost: float,
) -> npt.NDArray[np.int64]:
    """The detour over the unsealed grid, with the octile heuristic: no wave ran over it (a
    resumable wave stays resumable)."""
    cells, _ = detour_cells(
        a.state, OPEN_UNSEALED, goal, a.clean, start, obstacles, margin=margin,
        diagonal_cost=diagonal_cost,
    )  # fmt: skip
    return cells

"""The path ahead goes around (docs/api.md, "Stepping"): the robot's route ahead of a cell (its
detour, then the wave's walk), where this step's blocked cells first cut it within the
horizon, and how far the search for a way round looks (a window round the robot, beyond which
the plan's wave takes over)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from planner.plans.decide import Rule
from planner.plans.planning import Plan
from planner.plans.resumable_wave import ResumableWave
from planner.plans.walk import walk_fields
from planner.poses.blocked import reachable
from planner.stepping.state import SessionState

__all__ = ["blocked_ahead", "horizon_cells", "route_ahead", "window_cells"]


def horizon_cells(plan: Plan) -> int:
    """Moves of the route the horizon needs at least: ``horizon_m`` in cells, and two more."""
    return math.ceil(plan.params.horizon_m / plan.analysis.frame.resolution) + 2


def window_cells(plan: Plan) -> int:
    """The Chebyshev radius (cells) of the window a step searches for a way round: the horizon
    and the obstacles' margin on both sides of the way, so that the detour, which leaves the
    window, covers the horizon."""
    return horizon_cells(plan) + 2 * plan.params.dynamic_margin + 2


def route_ahead(
    plan: Plan, state: SessionState, cell: tuple[int, int], steps: int
) -> npt.NDArray[np.int64]:
    """The robot's route from ``cell`` (flat, ``cell`` first), at least ``steps`` moves unless
    it ends at the goal: the session's detour, and the wave's walk on from its end (a detour
    a step found ends where the wave takes over); without a detour, the walk."""
    W = plan.analysis.shape[1]
    here = np.array([cell[0] * W + cell[1]], dtype=np.int64)
    if not state.detour:
        return _walk(plan, cell, steps)
    detour = np.array(state.detour[:steps], dtype=np.int64)
    if detour.size < steps and detour[-1] != plan.goal[0] * W + plan.goal[1]:
        end = divmod(int(detour[-1]), W)
        detour = np.concatenate((detour, _walk(plan, end, steps - detour.size)[1:]))
    return np.concatenate((here, detour))


def blocked_ahead(
    plan: Plan, state: SessionState, cell: tuple[int, int], obstacles: npt.NDArray[np.int64]
) -> int:
    """The first cell (flat) of the route ahead of ``cell``, within the horizon, that the
    robot cannot reach for the ``obstacles`` (their cells and the margin; or a diagonal move
    past one), or -1 when they leave it clear."""
    if obstacles.shape[0] == 0:
        return -1
    route = route_ahead(plan, state, cell, horizon_cells(plan))
    margin = plan.params.dynamic_margin
    n = reachable(route, plan.analysis.shape, obstacles, margin=margin, exempt=0)
    return int(route[n]) if n < len(route) else -1


def _walk(plan: Plan, cell: tuple[int, int], steps: int) -> npt.NDArray[np.int64]:
    """The wide decision's walk from ``cell`` with no dynamic obstacles (flat, ``cell`` first),
    at most ``steps`` moves. The wide one whatever the plan's: the paper's next moves depend on
    the cells the robot has visited, which a step does not read."""
    a = plan.analysis
    W = a.shape[1]
    r, c = cell
    if cell == plan.goal:
        return np.array([r * W + c], dtype=np.int64)
    wave, rule = plan.wave, Rule.of(plan.params, wide=True)
    if isinstance(wave, ResumableWave):
        way = wave.walk((r, c), rule, steps, partial=True)
    else:
        view = wave.view(r, c, a.clean)
        goal = plan.goal[0] * W + plan.goal[1]
        way = walk_fields(view, r * W + c, goal, rule, max_steps=steps, partial=True)
    if way.size == 0:  # no way down the wave from there (a sealed pocket): the cell alone
        return np.array([r * W + c], dtype=np.int64)
    return way

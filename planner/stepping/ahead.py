"""The path ahead of a stepping robot (docs/api.md, "Stepping with poses"): the cells of its
route from where it is, as far as the horizon needs and this step's dynamic obstacles let it,
smoothed into poses, and the meters left to the goal."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from planner.plans.decide import Rule
from planner.plans.planning import Plan
from planner.plans.resumable_wave import ResumableWave
from planner.plans.walk import walk_fields
from planner.poses.ahead import poses_ahead
from planner.stepping.state import Pose, SessionState, Step

__all__ = ["path_ahead"]

_EXTEND = 4  # times the route ahead is lengthened when its poses fall short of the horizon


def path_ahead(
    plan: Plan,
    state: SessionState,
    step: Step,
    obstacles: npt.NDArray[np.int64],
    *,
    reported: bool,
    point: tuple[float, float] | None,
    yaw: float | None,
) -> tuple[tuple[Pose, ...], float | None]:
    """The step's ``poses`` and ``remaining_m``.

    The route starts at the robot's cell when the step ``reported`` it (from ``point``, else
    its cell's center), through the cell the step moves it to, else at that cell's center; it
    follows the session's detour if it has one, else the decision's walk down the wave with no
    dynamic obstacles, for the cells the horizon needs; it stops before a cell the obstacles
    block (or a diagonal move past one). ``remaining_m``: the poses' length, and from the cell
    where they end, ``k`` in meters (None when the goal is out of reach).
    """
    a, p = plan.analysis, plan.params
    frame = a.frame
    res = frame.resolution
    W = a.shape[1]
    cs = a.cspace
    moved = reported and step.previous != step.position
    first = step.previous if reported else step.position
    head = [first[0] * W + first[1]]
    if moved:
        head.append(step.position[0] * W + step.position[1])
    goal = plan.goal[0] * W + plan.goal[1]
    steps = math.ceil(p.horizon_m / res) + 2
    for _ in range(_EXTEND):
        rest = _ahead_of(plan, state, step, steps)
        route = np.concatenate((np.array(head, dtype=np.int64), rest))
        poses, n, length = poses_ahead(
            route, a.clearance, obstacles, margin=p.dynamic_margin, exempt=int(moved),
            resolution=res, origin=frame.origin,
            robot_radius=0.0 if cs is None else cs.robot_radius, start=point, start_yaw=yaw,
            outside_blocked=cs is None or cs.unknown == "blocked",
        )  # fmt: skip
        short = n == len(route) and route[-1] != goal and rest.size >= steps
        if not short or length >= p.horizon_m:
            break
        steps *= 2
    end_flat = int(route[n - 1])
    remaining_m = None
    if step.remaining is not None:
        remaining_m = length + _meters_to_go(plan, state, end_flat)
        remaining_m = remaining_m if math.isfinite(remaining_m) else None
    out: tuple[Pose, ...] = tuple(map(tuple, poses.tolist()))
    return out, remaining_m


def _ahead_of(plan: Plan, state: SessionState, step: Step, steps: int) -> npt.NDArray[np.int64]:
    """The route's cells after the step's ``position`` (flat), at most ``steps`` of them."""
    a = plan.analysis
    W = a.shape[1]
    r, c = step.position
    if step.move == "WAIT" or step.position == plan.goal:
        return np.empty(0, dtype=np.int64)
    if state.detour:
        return np.array(state.detour[:steps], dtype=np.int64)
    wave, rule = plan.wave, Rule.of(plan.params)
    if isinstance(wave, ResumableWave):
        way = wave.walk((r, c), rule, steps, partial=True)
    else:
        view = wave.view(r, c, a.clean)
        goal = plan.goal[0] * W + plan.goal[1]
        way = walk_fields(view, r * W + c, goal, rule, max_steps=steps, partial=True)
    return way[1:]


def _meters_to_go(plan: Plan, state: SessionState, flat: int) -> float:
    """Meters from a route cell to the goal along the grid: ``k`` (moves of 1 and
    ``diagonal_cost`` cells) times the resolution; off the wave's grid, along the detour."""
    W = plan.analysis.shape[1]
    r, c = divmod(flat, W)
    if (r, c) == plan.goal:
        return 0.0
    k = plan.wave.k_at(r, c)
    if not math.isfinite(k) and flat in state.detour:
        rest = np.array([flat, *state.detour[state.detour.index(flat) + 1 :]])
        rows, cols = np.divmod(rest, W)
        diagonal = (np.diff(rows) != 0) & (np.diff(cols) != 0)
        k = float(np.count_nonzero(~diagonal) + np.count_nonzero(diagonal) * math.sqrt(2.0))
    return k * plan.analysis.frame.resolution

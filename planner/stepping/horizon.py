"""A step's horizon (docs/api.md, "Stepping with poses"): which cells of the robot's route lie
ahead of it, from where it is, as far as the horizon needs (its detour round this step's
dynamic obstacles, found by the step, then the walk down the wave); their poses (by
:func:`~planner.poses.route_poses.poses_ahead`), and the meters left to the goal."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from planner.motion.robots import robot_of
from planner.plans.planning import Plan
from planner.poses.route_poses import poses_ahead
from planner.stepping.ahead import horizon_cells, route_ahead
from planner.stepping.shaped import shaped_ahead
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
    its cell's center), through the cell the step moves it to, else at that cell's center. It
    follows the session's detour if it has one (the step found it where the obstacles cut the
    way: :mod:`planner.stepping.ahead`), then the wide decision's walk down the wave, for the
    cells the horizon needs. It stops before a cell the obstacles block (or a diagonal move past
    one): only where no way round exists. ``remaining_m``: the poses' length, then along the
    detour from the cell where they end and ``k`` in meters from its end (None when the goal is
    out of reach).
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
    steps = horizon_cells(plan)
    # The plan's goal point as given (or the one it planned to instead): the poses end there.
    end = plan.goal_used if plan.goal_used is not None else plan.goal_point
    for _ in range(_EXTEND):
        rest = _ahead_of(plan, state, step, steps)
        route = np.concatenate((np.array(head, dtype=np.int64), rest))
        poses, n, length = poses_ahead(
            route, a.clearance, obstacles, margin=p.dynamic_margin, exempt=int(moved),
            resolution=res, origin=frame.origin,
            robot_radius=0.0 if cs is None else cs.robot_radius, start=point, start_yaw=yaw,
            goal=end if route[-1] == goal else None, goal_yaw=plan.goal_yaw,
            outside_blocked=cs is None or cs.unknown == "blocked",
        )  # fmt: skip
        short = n == len(route) and route[-1] != goal and rest.size >= steps
        if not short or length >= p.horizon_m:
            break
        steps *= 2
    robot = robot_of(p, res)
    if robot is not None:  # a footprint or a car: its own poses, checked (docs/shapes.md)
        x, y = point if point is not None else frame.centers([first])[0]
        on_plan = not state.detour and len(poses) > 1
        poses = shaped_ahead(
            plan, robot, poses, obstacles, on_plan=on_plan, here=(float(x), float(y)), yaw=yaw
        )
    end_flat = int(route[n - 1])
    remaining_m = None
    if step.remaining is not None:
        remaining_m = length + _meters_to_go(plan, state, end_flat)
        remaining_m = remaining_m if math.isfinite(remaining_m) else None
    out: tuple[Pose, ...] = tuple(map(tuple, poses.tolist()))
    return out, remaining_m


def _ahead_of(plan: Plan, state: SessionState, step: Step, steps: int) -> npt.NDArray[np.int64]:
    """The route's cells after the step's ``position`` (flat): its detour, then the wave's walk,
    ``steps`` of them at least (unless at the goal)."""
    if step.move == "WAIT" or step.position == plan.goal:
        return np.empty(0, dtype=np.int64)
    return route_ahead(plan, state, step.position, steps)[1:]


def _meters_to_go(plan: Plan, state: SessionState, flat: int) -> float:
    """Meters from a route cell to the goal along the route: on the session's detour, along it
    to its end, then ``k`` from there (where the wave takes over); else ``k`` (moves of 1 and
    ``diagonal_cost`` cells) times the resolution."""
    W = plan.analysis.shape[1]
    r, c = divmod(flat, W)
    if (r, c) == plan.goal:
        return 0.0
    k = 0.0
    if flat in state.detour:
        rest = np.array([flat, *state.detour[state.detour.index(flat) + 1 :]])
        rows, cols = np.divmod(rest, W)
        diagonal = (np.diff(rows) != 0) & (np.diff(cols) != 0)
        k = float(np.count_nonzero(~diagonal) + np.count_nonzero(diagonal) * math.sqrt(2.0))
        r, c = divmod(int(rest[-1]), W)
    if (r, c) != plan.goal:
        k += plan.wave.k_at(r, c)
    return k * plan.analysis.frame.resolution

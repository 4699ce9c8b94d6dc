"""A plan's robot: its footprint and motion from the plan's parameters, and its path."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.errors import InvalidInput
from planner.footprint import HEADING_BINS, Footprint, footprint_cells, footprint_of
from planner.motion.collide import grid_of, poses_free
from planner.motion.follow import follow
from planner.motion.hybrid import MotionPath, Robot, drive
from planner.params import Params

__all__ = [
    "SEARCH_SECONDS",
    "MotionPath",
    "arrived_as",
    "check_goal_yaw",
    "check_waypoint_yaws",
    "fits_at",
    "motion_path",
    "robot_of",
]

SEARCH_SECONDS = 5.0
"""About how long a plan's hybrid search may run (well within a request's timeout)."""

_DISC_SIDES = 16


def robot_of(params: Params, resolution: float) -> Robot | None:
    """The robot ``params`` describe when it is more than a disc turning in place (a footprint
    or a car motion), else None. A car without a footprint is the polygon of 16 sides around
    its ``robot_radius`` disc (at least a quarter cell)."""
    if params.footprint is None and params.motion == "diff":
        return None
    if params.footprint is not None:
        fp = footprint_of(list(params.footprint))
    else:
        r = max(params.robot_radius, resolution / 4) / math.cos(math.pi / _DISC_SIDES)
        a = np.arange(_DISC_SIDES) * 2 * math.pi / _DISC_SIDES
        fp = Footprint(tuple((float(x), float(y)) for x, y in zip(r * np.cos(a), r * np.sin(a),
                                                                     strict=True)))  # fmt: skip
    return Robot(fp, params.motion, params.min_turning_radius or 0.0)


def fits_at(
    analysis: Analysis, params: Params, yaw: float | None
) -> Callable[[npt.NDArray[np.float64]], npt.NDArray[np.bool_]] | None:
    """For a robot with a footprint or a car motion, whether its footprint is free at each
    point ``(n, 2)`` (meters) at ``yaw`` (at some heading, without one); None for a disc
    turning in place (its analysis says where it stands)."""
    robot = robot_of(params, analysis.frame.resolution)
    if robot is None:
        return None
    grid = grid_of(analysis)
    cells = footprint_cells(robot.footprint, grid.frame.resolution, bins=HEADING_BINS)
    headings = np.arange(HEADING_BINS) * 2 * math.pi / HEADING_BINS if yaw is None else [yaw]

    def fits(points: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
        xy = np.repeat(np.asarray(points, dtype=np.float64).reshape(-1, 2), len(headings), 0)
        at = np.column_stack([xy, np.tile(headings, len(xy) // len(headings))])
        free: npt.NDArray[np.bool_] = poses_free(grid, cells, grid.to_grid(at))
        out: npt.NDArray[np.bool_] = np.asarray(free.reshape(-1, len(headings)).any(axis=1))
        return out

    return fits


def check_goal_yaw(params: Params, goal_yaw: float | None) -> None:
    """A car motion needs the goal's yaw (it cannot turn in place to meet one): without, 422."""
    if params.motion != "diff" and goal_yaw is None:
        msg = (
            f"a {params.motion} motion needs the goal's yaw (a car cannot turn in place to "
            "meet one): give the goal as {x, y, yaw}"
        )
        raise InvalidInput(msg, field="goal")


def check_waypoint_yaws(params: Params, waypoints: list[Any]) -> None:
    """A car motion needs a yaw at every waypoint, as at the goal: without, 422 naming it."""
    if params.motion == "diff":
        return
    for i, point in enumerate(waypoints):
        if not isinstance(point, Mapping) or point.get("yaw") is None:
            msg = (
                f"a {params.motion} motion needs a yaw at every waypoint (a car cannot turn in "
                f"place to meet one): give waypoints[{i}] as {{x, y, yaw}}"
            )
            raise InvalidInput(msg, field=f"waypoints[{i}]")


def arrived_as(params: Params, resolution: float, start: Any, last: Any) -> Any:
    """A route leg's ``start`` (the waypoint the leg before ended at, its ``last`` pose): for a
    robot with a footprint or a car motion and a waypoint without a yaw, that pose's point and
    heading, so that the next leg goes on as the robot arrived (no turn at the join that the
    footprint was not checked for); else ``start`` as given."""
    if robot_of(params, resolution) is None or (isinstance(start, Mapping) and
                                                 start.get("yaw") is not None):  # fmt: skip
        return start
    x, y, yaw = (float(v) for v in last)
    return {"x": x, "y": y, "yaw": yaw}


def motion_path(
    analysis: Analysis,
    wave: Any,
    params: Params,
    start: tuple[tuple[float, float], float | None],
    goal: tuple[tuple[float, float], float | None],
    *,
    guide: Callable[[], npt.NDArray[np.float64]] | None = None,
    seconds: float = SEARCH_SECONDS,
) -> MotionPath | None:
    """The path of the robot of ``params`` from ``start`` to ``goal`` (``((x, y), yaw or
    None)``, meters) on the analysis, with ``wave`` (the plan's goal wave) as the search's
    heuristic, found within about ``seconds``; None for a disc turning in place (its poses are
    the smoothed grid path's). A footprint turning in place follows ``guide``'s poses (the
    plan's smoothed grid path) where it fits along them (:func:`~planner.motion.follow.follow`);
    a car is searched for."""
    robot = robot_of(params, analysis.frame.resolution)
    if robot is None:
        return None
    (sx, sy), syaw = start
    (gx, gy), gyaw = goal
    wide = {"wide_weight": params.wide_weight, "wide_distance": params.wide_distance}
    if robot.motion == "diff" and guide is not None:
        try:
            poses = guide()
        except InvalidInput:  # the inscribed disc's smoothing refused: the search decides
            poses = None
        if poses is not None:
            return follow(analysis, wave.kw, robot, poses, (sx, sy, syaw), (gx, gy, gyaw),
                          seconds=seconds, **wide)  # fmt: skip
    return drive(analysis, wave.kw, robot, (sx, sy, syaw), (gx, gy, gyaw), seconds=seconds, **wide)

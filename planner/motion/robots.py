"""A plan's robot: its footprint and motion from the plan's parameters, and its path."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.errors import InvalidInput
from planner.footprint import Footprint, footprint_of
from planner.motion.follow import follow
from planner.motion.hybrid import MotionPath, Robot, drive
from planner.params import Params

__all__ = ["SEARCH_SECONDS", "MotionPath", "check_goal_yaw", "motion_path", "robot_of"]

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


def check_goal_yaw(params: Params, goal_yaw: float | None) -> None:
    """A car motion needs the goal's yaw (it cannot turn in place to meet one): without, 422."""
    if params.motion != "diff" and goal_yaw is None:
        msg = (
            f"a {params.motion} motion needs the goal's yaw (a car cannot turn in place to "
            "meet one): give the goal as {x, y, yaw}"
        )
        raise InvalidInput(msg, field="goal")


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

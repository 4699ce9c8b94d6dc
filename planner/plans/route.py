"""Routes through waypoints: a plan made of legs (start, each waypoint in order, the goal), each
planned with the same preset and parameters down its own goal wave, joined into one path and
one set of poses whose every waypoint's point is a pose."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Generic, Protocol, TypeVar, cast

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.errors import InvalidInput, NoValidPath, quote
from planner.plans.ends import end_yaw, free_cell, stand_on, tolerance_m
from planner.plans.whole_wave import Wave
from planner.poses.polyline import wrap_angle
from planner.poses.smooth import MAX_TURN

__all__ = [
    "MAX_WAYPOINTS",
    "Leg",
    "Route",
    "join_poses",
    "plan_route",
    "route_of",
    "waypoint_list",
]

MAX_WAYPOINTS = 64
"""Waypoints a route takes at most."""

_TURN_STEP = math.radians(14.9)  # below MAX_TURN, as the smoother's turns in place


class Leg(Protocol):
    """What a route reads of its legs: a :class:`~planner.Plan` (this module does not import
    it: ``planning`` imports this one)."""

    @property
    def start(self) -> tuple[int, int]: ...
    @property
    def goal(self) -> tuple[int, int]: ...
    @property
    def wave(self) -> Wave: ...
    @property
    def path(self) -> npt.NDArray[np.int64]: ...
    @property
    def poses(self) -> npt.NDArray[np.float64]: ...
    @property
    def directions(self) -> npt.NDArray[np.int8]: ...
    @property
    def length(self) -> float: ...
    @property
    def arc_cost(self) -> float: ...
    @property
    def start_point(self) -> tuple[float, float] | None: ...
    @property
    def start_yaw(self) -> float | None: ...
    @property
    def goal_yaw(self) -> float | None: ...
    @property
    def narrow_fallback(self) -> bool: ...
    @property
    def elapsed_ms(self) -> float: ...


L = TypeVar("L", bound=Leg)


@dataclass(frozen=True, eq=False)
class Route(Generic[L]):
    """The legs of a plan through waypoints: ``legs[i]`` goes to ``waypoints[i]`` (its goal
    cell and point), the last to the goal. ``known_costs``, when given: each leg's plain
    cost-to-go ``k`` from its start, as :attr:`costs` would compute it (a stored plan keeps
    them, so that a step reads no wave but its own leg's)."""

    legs: tuple[L, ...]
    known_costs: tuple[float, ...] = ()

    @property
    def waypoints(self) -> list[tuple[int, int]]:
        """The waypoints' cells, in order."""
        return [leg.goal for leg in self.legs[:-1]]

    @cached_property
    def costs(self) -> tuple[float, ...]:
        """Each leg's plain cost-to-go ``k`` from its start to its goal (cells)."""
        if len(self.known_costs) == len(self.legs):
            return self.known_costs
        return tuple(float(leg.wave.k_at(*leg.start)) for leg in self.legs)

    @cached_property
    def path(self) -> npt.NDArray[np.int64]:
        """The legs' paths end to end, each waypoint's cell once."""
        parts = [self.legs[0].path, *(leg.path[1:] for leg in self.legs[1:])]
        out: npt.NDArray[np.int64] = np.concatenate(parts)
        return out

    @property
    def cost(self) -> tuple[float, float]:
        """(length, arc cost) over the legs."""
        return (
            float(sum(leg.length for leg in self.legs)),
            float(sum(leg.arc_cost for leg in self.legs)),
        )

    @cached_property
    def _joined(self) -> tuple[npt.NDArray[np.float64], tuple[int, ...]]:
        return join_poses(self.legs)

    @property
    def directions(self) -> npt.NDArray[np.int8]:
        """The direction (1 forward, -1 reverse) of the motion reaching each of :attr:`poses`."""
        return self._joined[0][:, 3].astype(np.int8)

    @property
    def poses(self) -> npt.NDArray[np.float64]:
        """The legs' poses end to end (see :func:`join_poses`)."""
        return self._joined[0][:, :3]

    @property
    def waypoint_indices(self) -> tuple[int, ...]:
        """The index in :attr:`poses` of each waypoint's pose."""
        return self._joined[1]


def waypoint_list(waypoints: Any) -> list[Any]:
    """``waypoints`` checked: a list of at most :data:`MAX_WAYPOINTS` cells or points."""
    if waypoints is None:
        return []
    if isinstance(waypoints, str | bytes | Mapping) or not isinstance(
        waypoints, Sequence | np.ndarray
    ):
        msg = f"waypoints must be a list of cells or points; got {quote(waypoints)}"
        raise InvalidInput(msg, field="waypoints")
    if len(waypoints) > MAX_WAYPOINTS:
        msg = f"{len(waypoints)} waypoints given; at most {MAX_WAYPOINTS}"
        raise InvalidInput(msg, field="waypoints")
    return list(waypoints)


def plan_route(
    analysis: Analysis,
    start: Any,
    waypoints: list[Any],
    goal: Any,
    leg: Callable[[Any, Any, Any], L],
    goal_tolerance: Any,
) -> L:
    """The plan from ``start`` through each of ``waypoints`` in order to ``goal``: ``leg(a, b,
    tolerance)`` plans each leg (the goal's tolerance on the last only). A waypoint the robot
    cannot stand on is refused as the goal would be, named ``waypoints[i]`` (code
    ``WAYPOINT_OCCUPIED``); one it cannot reach is ``NO_VALID_PATH``, named so too."""
    tolerance_m(goal_tolerance)  # refused before any leg is planned
    names = [f"waypoints[{i}]" for i in range(len(waypoints))]
    for name, point in zip(names, waypoints, strict=True):
        cell = free_cell(analysis, point, name, code="WAYPOINT_OCCUPIED")
        end_yaw(point, name)
        stand_on(analysis, point, cell, name, code="WAYPOINT_OCCUPIED")
    ends = [start, *waypoints, goal]
    labels = ["start", *names, "goal"]
    legs: list[L] = []
    for i in range(len(ends) - 1):
        last = i == len(ends) - 2
        try:
            legs.append(leg(ends[i], ends[i + 1], goal_tolerance if last else 0.0))
        except NoValidPath as error:
            # The leg's own words (goal, start) made the route's (waypoints[i]).
            message = error.message.removeprefix("NO_VALID_PATH: ")
            message = message.replace("goal ", f"{labels[i + 1]} ", 1)
            message = message.replace("from start ", f"from {labels[i]} ", 1)
            raise NoValidPath(message, field=labels[i + 1]) from None
    return route_of(legs)


def route_of(legs: Sequence[L], costs: Sequence[float] = ()) -> L:
    """The plan of a route from its legs (each a :class:`~planner.Plan` whose start is the
    previous one's goal): the first leg's start, the last leg's goal, wave and parameters."""
    first, last = legs[0], legs[-1]
    plan: L = dataclasses.replace(
        cast(Any, last),
        start=first.start,
        start_point=first.start_point,
        start_yaw=first.start_yaw,
        narrow_fallback=any(leg.narrow_fallback for leg in legs),
        elapsed_ms=sum(leg.elapsed_ms for leg in legs),
        route=Route(tuple(legs), tuple(float(c) for c in costs)),
    )
    return plan


def _between(a: float, c: float, b: float) -> bool:
    """Whether heading ``c`` lies on the shorter turn from ``a`` to ``b``."""
    return abs(wrap_angle(c - a)) + abs(wrap_angle(b - c)) <= abs(wrap_angle(b - a)) + 1e-9


def _passes(p: list[float], q: list[float]) -> bool:
    """Whether the step from pose ``p`` to pose ``q`` keeps the poses' rules: a turn of at most
    15 degrees, and the step's direction between their yaws."""
    if abs(wrap_angle(q[2] - p[2])) > MAX_TURN:
        return False
    dx, dy = q[0] - p[0], q[1] - p[1]
    return math.hypot(dx, dy) == 0.0 or _between(p[2], math.atan2(dy, dx), q[2])


def join_poses(legs: Sequence[Leg]) -> tuple[npt.NDArray[np.float64], tuple[int, ...]]:
    """The legs' poses end to end, and the index of each waypoint's pose.

    At a waypoint with a yaw, both legs turn in place to meet it (the one pose between them
    has it). At one without, the heading there is halfway between the way in and the way out:
    one pose when the turns from the pose before and to the pose after stay within 15 degrees,
    else a turn in place from the way in, through that heading, to the way out. No two
    consecutive poses are alike. Each pose carries the direction of the motion reaching it
    (``[x, y, yaw, direction]``)."""
    out: list[list[float]] = []
    loose = True  # whether the last pose's yaw says nothing yet (a leg that does not move)
    indices: list[int] = []
    for k, leg in enumerate(legs):
        nxt: list[list[float]] = np.column_stack([leg.poses, leg.directions]).tolist()
        idle = leg.start_yaw is None and leg.goal_yaw is None
        idle = idle and all(q[0] == nxt[0][0] and q[1] == nxt[0][1] for q in nxt)
        if k == 0:
            out, loose = nxt, idle
            continue
        if idle:  # a waypoint where the robot already is, with no yaw: nothing to do there
            indices.append(len(out) - 1)
            continue
        x, y = out[-1][0], out[-1][1]
        nxt[0][0], nxt[0][1] = x, y  # the waypoint's point, to the bit
        a, d = out[-1][2], nxt[0][2]
        turn = wrap_angle(d - a)
        if loose or legs[k - 1].goal_yaw is not None or turn == 0.0:
            out[-1] = [*nxt[0][:3], out[-1][3]]
            indices.append(len(out) - 1)
            out += nxt[1:]
            loose = False
            continue
        h = wrap_angle(a + turn / 2)
        merged = [x, y, h, 1.0]
        prior = out[-2] if len(out) > 1 else None
        after = nxt[1] if len(nxt) > 1 else None
        if (prior is None or _passes(prior, merged)) and (after is None or _passes(merged, after)):
            out[-1] = merged
            indices.append(len(out) - 1)
            out += nxt[1:]
            continue
        n = math.ceil(abs(turn / 2) / _TURN_STEP)
        out += [[x, y, wrap_angle(a + turn / 2 * q / n), 1.0] for q in range(1, n + 1)]
        indices.append(len(out) - 1)
        out += [[x, y, wrap_angle(h + turn / 2 * q / n), 1.0] for q in range(1, n)]
        out += nxt
    poses = np.array(out, dtype=np.float64).reshape(-1, 4)
    keep = np.ones(len(poses), dtype=bool)
    keep[1:] = (poses[1:, :3] != poses[:-1, :3]).any(axis=1)
    shift = np.cumsum(~keep)
    joined = tuple(int(i - shift[i]) for i in indices)
    out_poses: npt.NDArray[np.float64] = poses[keep]
    return out_poses, joined

"""``plan()``: analysis, goal wave, the narrow fallback, and the path the decision follows."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis, analyse, analyse_map, params_key
from planner.errors import InvalidInput, NoValidPath, quote
from planner.maps.grids import as_grid
from planner.maps.robot_maps import RobotMap, grid_map
from planner.motion.robots import (
    SEARCH_SECONDS,
    MotionPath,
    arrived_as,
    check_goal_yaw,
    check_waypoint_yaws,
    fits_at,
    motion_path,
)
from planner.params import PARAMETER_RANGES, Params, resolve_params
from planner.plans.bounded import Detour, bound_detour, bound_route
from planner.plans.decide import Rule
from planner.plans.ends import (
    cell_of,
    end_point,
    end_yaw,
    free_cell,
    nearest_reachable,
    stand_on,
    tolerance_m,
)
from planner.plans.metrics import clearance_metrics, path_cost
from planner.plans.reach import route, wave_to
from planner.plans.resumable_wave import resumable_wave
from planner.plans.route import Route, plan_route, route_of, waypoint_list
from planner.plans.summary import plan_summary
from planner.plans.whole_wave import Wave, goal_wave
from planner.poses.smooth import smooth_path
from planner.poses.speed import duration, pose_speeds

__all__ = ["Plan", "clearance_metrics", "path_cost", "plan"]

WaveSource = Callable[[tuple[int, int], bool], Wave]
"""Gives the goal wave of a goal cell for ``narrow`` (False: the sealed grid): lets a caller
cache waves."""


@dataclass(frozen=True, eq=False)
class Plan:
    """A plan: where the robot starts and goes, with what, and the path it would follow with no
    dynamic obstacles (``path``, an ``(n, 2)`` array of ``[row, col]`` from start to goal).

    The path and its figures are computed on first use, once: a robot stepping along a plan
    needs only its waves. The clearance figures need the map's distance transform, which the
    analysis then keeps.

    In meters: ``start_point`` and ``goal_point`` are the points as given (a cell: its center;
    None: the cell's center), ``start_yaw`` / ``goal_yaw`` their headings (radians) if given;
    ``goal_used`` the center of the cell planned to instead of ``goal_point`` when that could not
    be stood on or reached (within ``goal_tolerance``), else None.

    Through waypoints (:attr:`route`), the path, its figures and the poses are the whole
    route's.
    """

    start: tuple[int, int]
    goal: tuple[int, int]
    preset: str
    params: Params
    analysis: Analysis
    wave: Wave
    narrow_fallback: bool
    elapsed_ms: float
    start_point: tuple[float, float] | None = None
    goal_point: tuple[float, float] | None = None
    start_yaw: float | None = None
    goal_yaw: float | None = None
    goal_used: tuple[float, float] | None = None
    goal_tolerance: float = 0.0
    route: Route[Plan] | None = None
    """The legs of a plan through waypoints (the plan's ``wave`` is then the last leg's), else
    None."""
    detour: Detour | None = None
    """How the ``wide`` route compares with the shortest (``params.max_detour``), else None."""
    search_seconds: float = SEARCH_SECONDS
    """How long a footprint's or a car's search may run (then ``NO_VALID_PATH``)."""

    @cached_property
    def path(self) -> npt.NDArray[np.int64]:
        """The cells the decision visits with no dynamic obstacles, start to goal."""
        if self.route is not None:
            return self.route.path
        s, g = self.start, self.goal
        flat = route(self.wave, self.analysis, s, g, Rule.of(self.params))
        if flat.size == 0:  # cannot happen: a finite kw always has a descending neighbour
            raise NoValidPath(f"the decision did not reach goal {list(g)} from start {list(s)}")
        path: npt.NDArray[np.int64] = np.stack(np.divmod(flat, self.analysis.shape[1]), axis=1)
        return path

    @cached_property
    def _cost(self) -> tuple[float, float]:
        if self.route is not None:
            return self.route.cost
        return path_cost(self.path, self.wave)

    @property
    def length(self) -> float:
        """The path's length in cells: 1 a straight move, sqrt 2 a diagonal one, whatever the
        ``diagonal_cost`` the search weighed diagonals with (the paper's 1.4 in its presets):
        :attr:`length_m` divided by the resolution."""
        return self._cost[0]

    @property
    def arc_cost(self) -> float:
        """The paper's total arc cost: the sum of ``k`` over the cells entered after the start."""
        return self._cost[1]

    @cached_property
    def _clearance(self) -> tuple[float, float, float]:
        return clearance_metrics(self.path, self.analysis)

    @property
    def min_clearance(self) -> float:
        """Least distance from a path cell to the nearest static obstacle, in cells."""
        return self._clearance[0]

    @property
    def mean_clearance(self) -> float:
        """Mean distance from the path's cells to the nearest static obstacle, in cells."""
        return self._clearance[1]

    @property
    def contact_ratio(self) -> float:
        """Share of the path's cells touching an obstacle (clearance below 1.5)."""
        return self._clearance[2]

    @cached_property
    def path_xy(self) -> npt.NDArray[np.float64]:
        """The path's cell centers in the map frame, meters: ``(n, 2)`` ``[x, y]``."""
        return self.analysis.frame.centers(self.path)

    @property
    def length_m(self) -> float:
        """The path's length in meters: the distances between its cell centers."""
        steps = np.abs(np.diff(self.path, axis=0)).sum(axis=1)
        cells = np.count_nonzero(steps == 1) + np.count_nonzero(steps == 2) * math.sqrt(2.0)
        return float(cells) * self.analysis.frame.resolution

    def _center(self, cell: tuple[int, int]) -> tuple[float, float]:
        x, y = self.analysis.frame.centers([cell])[0]
        return float(x), float(y)

    @property
    def goal_offset_m(self) -> float:
        """How far ``goal_used`` is from ``goal_point``, meters (0 when the goal is as given)."""
        if self.goal_used is None or self.goal_point is None:
            return 0.0
        return math.dist(self.goal_used, self.goal_point)

    @cached_property
    def poses(self) -> npt.NDArray[np.float64]:
        """``(m, 3)`` ``[x, y, yaw]`` in meters: the path a robot controller follows, from the
        start point to the goal point (or ``goal_used``), smoothed by
        :func:`~planner.poses.smooth_path` keeping the path's clearance, the last yaw
        ``goal_yaw`` when given (docs/api.md, "Poses"); through waypoints, the legs' poses
        joined (:func:`~planner.plans.route.join_poses`)."""
        if self.route is not None:
            return self.route.poses
        return self._smoothed if self.motion is None else self.motion.poses

    @cached_property
    def _smoothed(self) -> npt.NDArray[np.float64]:
        """The grid path smoothed for the analysis's disc (a footprint turning in place follows
        it where it fits)."""
        a = self.analysis
        cs = a.cspace
        start = self.start_point
        goal = self.goal_used if self.goal_used is not None else self.goal_point
        # A cell's center goes as None: the smoother's own center, no tiny first segment.
        if start == self._center(self.start):
            start = None
        if goal == self._center(self.goal):
            goal = None
        return smooth_path(
            self.path,
            a.clearance,
            resolution=a.frame.resolution,
            origin=a.frame.origin,
            robot_radius=cs.robot_radius if cs is not None else 0.0,
            start=start,
            goal=goal,
            start_yaw=self.start_yaw,
            goal_yaw=self.goal_yaw,
            outside_blocked=cs is None or cs.unknown == "blocked",
        )

    @cached_property
    def motion(self) -> MotionPath | None:
        """With a footprint or a car motion, the footprint's path (its poses are the plan's)."""
        if self.route is not None:
            return None
        goal = self.goal_used if self.goal_used is not None else self.goal_point
        return motion_path(
            self.analysis, self.wave, self.params,
            (self.start_point or self._center(self.start), self.start_yaw),
            (goal or self._center(self.goal), self.goal_yaw),
            guide=lambda: self._smoothed, seconds=self.search_seconds,
        )  # fmt: skip

    @property
    def directions(self) -> npt.NDArray[np.int8]:
        """The direction (1 forward, -1 reverse) of the motion reaching each of :attr:`poses`."""
        if self.route is not None:
            return self.route.directions
        m = self.motion
        return np.ones(len(self.poses), np.int8) if m is None else m.direction

    @property
    def waypoints(self) -> list[tuple[int, int]]:
        """The cells of the waypoints the route passes, in order (none without a route)."""
        return [] if self.route is None else self.route.waypoints

    @property
    def waypoint_indices(self) -> list[int]:
        """The index in :attr:`poses` of each waypoint's pose."""
        return [] if self.route is None else list(self.route.waypoint_indices)

    @cached_property
    def max_speeds(self) -> npt.NDArray[np.float64]:
        """The speed cap at each of :attr:`poses` (m/s; ``inf`` outside every speed zone)."""
        return pose_speeds(self.analysis.zones, self.poses)

    @property
    def duration_s(self) -> float:
        """Seconds to drive :attr:`poses` (:func:`~planner.poses.speed.duration`)."""
        return duration(self.poses, self.directions, self.max_speeds, self.params)

    @property
    def length_poses_m(self) -> float:
        """The length of the poses' polyline, meters."""
        steps = np.diff(self.poses[:, :2], axis=0)
        return float(np.hypot(steps[:, 0], steps[:, 1]).sum())

    @property
    def min_clearance_m(self) -> float:
        """:attr:`min_clearance` in meters."""
        return self.min_clearance * self.analysis.frame.resolution

    @property
    def mean_clearance_m(self) -> float:
        """:attr:`mean_clearance` in meters."""
        return self.mean_clearance * self.analysis.frame.resolution

    @property
    def gates(self) -> int:
        return self.analysis.gates

    @property
    def tunnels(self) -> int:
        return self.analysis.tunnels

    def summary(self) -> dict[str, Any]:
        """The plan as plain JSON-ready data (:func:`~planner.plans.summary.plan_summary`)."""
        return plan_summary(self)


def plan(
    grid: Any,
    start: Any,
    goal: Any,
    *,
    preset: str = "wide",
    analysis: Analysis | None = None,
    waves: WaveSource | None = None,
    whole: bool = False,
    goal_tolerance: Any = 0.0,
    waypoints: Any = None,
    bounded: bool = True,
    search_seconds: float = SEARCH_SECONDS,
    **params: Any,
) -> Plan:
    """Plan from ``start`` to ``goal`` on a 0/1 occupancy ``grid`` or a :class:`RobotMap`.

    ``start`` and ``goal`` are ``[row, col]`` cells or points ``{"x": .., "y": ..}`` in meters
    (the cells containing them), a point with an optional heading ``"yaw"`` (finite radians; the
    last pose's yaw is the goal's). An off-center point the robot cannot stand on (too near a
    wall though its cell is traversable) is refused as ``START_OCCUPIED`` / ``GOAL_OCCUPIED``.
    With ``goal_tolerance`` (meters, >= 0) a goal that cannot be stood on or reached gives way to
    the reachable traversable cell nearest to it within the tolerance (``Plan.goal_used``).
    ``waypoints`` (at most 64 cells or points, a point with an optional ``yaw``): the path
    passes through each in order, each leg planned on its own (``Plan.route``). A ``wide``
    plan keeps to ``params.max_detour`` (``Plan.detour``) unless ``bounded`` is false; a route
    as a whole, its legs planned unbounded first (one share of the wall term for every leg: one
    set of effective parameters holds for the whole route). A footprint's
    or a car's search runs for at most about ``search_seconds`` (a request's time left).

    ``preset`` is one of ``wide`` (default), ``wfs-mmas``, ``mmas``, ``shortest``; keyword
    ``params`` override it one by one (see :class:`planner.Params`), among them
    ``robot_radius`` (meters) and ``unknown``. A caller that caches may pass the map's
    ``analysis`` (then ``grid`` may be None; build its cache key with :func:`analysis_key`) and a
    ``waves`` source. Without one, the plan's wave is a :class:`~planner.ResumableWave`,
    settled only as far as the robot needs (its time and memory grow with the region explored;
    its values are the whole-map wave's to the bit, so the path is the same), or, with
    ``whole``, a whole-map :func:`~planner.plans.whole_wave.goal_wave`.

    >>> p = plan([[0, 0, 0], [0, 1, 0], [0, 0, 0]], [0, 0], [2, 2], preset="shortest")
    >>> p.path.tolist(), round(p.length, 3)
    ([[0, 0], [0, 1], [0, 2], [1, 2], [2, 2]], 4.0)
    >>> plan([[0, 1], [1, 0]], [0, 0], [1, 1])
    Traceback (most recent call last):
    ...
    planner.errors.NoValidPath: NO_VALID_PATH: goal [1, 1] cannot be reached from start [0, 0]
    """
    t0 = time.perf_counter()
    p = resolve_params(preset, **params)
    if analysis is None:
        if isinstance(grid, RobotMap):
            analysis = analyse_map(grid, p)
        else:
            cells = as_grid(grid)
            radius, unknown, _, _, wall, *_ = params_key(p, plain=True)
            if (radius, unknown, wall) == (0.0, "blocked", "cells"):
                analysis = analyse(
                    cells,
                    seal_tunnels=p.seal_tunnels,
                    clean_weight=p.clean_weight,
                    clean_radius=p.clean_radius,
                )
            else:
                analysis = analyse_map(grid_map(cells), p)
    else:
        wanted = params_key(p, plain=analysis.plain)
        if analysis.params_key != wanted:
            msg = (
                "the analysis given was made with other parameters than the plan's: "
                f"{analysis.params_key!r} (robot_radius, unknown, "
                f"occupied_threshold, seal_tunnels, wall_cost, weights); the plan's params ask "
                f"for {wanted!r}"
            )
            raise InvalidInput(msg, field="params")
    through = waypoint_list(waypoints)
    if through:
        given, legs = analysis, list[Plan]()
        check_waypoint_yaws(p, through)

        def leg(a: Any, b: Any, tolerance: Any) -> Plan:
            if legs:  # on from the waypoint as the robot arrived there
                a = arrived_as(p, given.frame.resolution, a, legs[-1].poses[-1])
            legs.append(plan(
                None, a, b, preset=preset, analysis=given, waves=waves, whole=whole,
                goal_tolerance=tolerance, bounded=False, search_seconds=search_seconds, **params,
            ))  # fmt: skip
            return legs[-1]

        joined = plan_route(analysis, start, through, goal, leg, goal_tolerance)
        if bounded and p.decision == "wide" and (analysis.penalised or analysis.sealed):
            return bound_route(legs, route_of, whole=whole, t0=t0)
        return joined
    s = free_cell(analysis, start, "start")
    start_yaw, goal_yaw = end_yaw(start, "start"), end_yaw(goal, "goal")
    check_goal_yaw(p, goal_yaw)
    tolerance = tolerance_m(goal_tolerance)
    stand_on(analysis, start, s, "start")
    goal_cell = cell_of(analysis, goal, "goal")  # a goal outside the map is refused at once
    goal_xy = end_point(analysis, goal, goal_cell, "goal")

    def wave_for(g: tuple[int, int], narrow: bool) -> Wave:
        if waves is not None:
            return waves(g, narrow)
        if whole:
            return goal_wave(analysis, g, diagonal_cost=p.diagonal_cost, narrow=narrow)
        return resumable_wave(analysis, g, diagonal_cost=p.diagonal_cost, narrow=narrow)

    goal_used = None
    fits = fits_at(analysis, p, goal_yaw) if tolerance > 0 else None  # a footprint's goal
    try:
        g = free_cell(analysis, goal, "goal")
        stand_on(analysis, goal, g, "goal")
        if fits is not None and not fits(np.array([goal_xy]))[0]:
            msg = f"the footprint at goal {quote(goal)} holds a blocked cell's center"
            raise InvalidInput(msg, field="goal", code="GOAL_OCCUPIED")
        wave, narrow = wave_to(analysis, s, g, p.allow_narrow, wave_for)
    except (InvalidInput, NoValidPath) as error:
        if tolerance <= 0:
            raise
        near = nearest_reachable(
            analysis, s, goal_xy, tolerance,
            diagonal_cost=p.diagonal_cost, allow_narrow=p.allow_narrow, fits=fits,
        )  # fmt: skip
        if near is None:
            error.message += (
                f" (no reachable traversable cell within goal_tolerance {tolerance:g} m)"
            )
            error.args = (error.message,)
            raise
        g = near
        wave, narrow = wave_to(analysis, s, g, p.allow_narrow, wave_for)
        x, y = analysis.frame.centers([g])[0]
        goal_used = (float(x), float(y))
    if p.dynamic_margin_m is not None:
        p = dataclasses.replace(p, dynamic_margin=_margin_cells(p.dynamic_margin_m, analysis))
    result = Plan(
        start=s,
        goal=g,
        preset=preset,
        params=p,
        analysis=analysis,
        wave=wave,
        narrow_fallback=narrow,
        elapsed_ms=(time.perf_counter() - t0) * 1e3,
        start_point=end_point(analysis, start, s, "start"),
        goal_point=goal_xy,
        start_yaw=start_yaw,
        goal_yaw=goal_yaw,
        goal_used=goal_used,
        goal_tolerance=tolerance,
        search_seconds=search_seconds,
    )
    if bounded and p.decision == "wide" and (analysis.penalised or analysis.sealed):
        return bound_detour(result, whole=whole, t0=t0)
    return result


def _margin_cells(meters: float, analysis: Analysis) -> int:
    """``dynamic_margin_m`` in cells of the analysed map: every cell an obstacle within that many
    meters may cover."""
    resolution = analysis.frame.resolution
    cells = math.ceil(meters / resolution - 1e-9)
    high = int(PARAMETER_RANGES["dynamic_margin"][1])
    if cells > high:
        msg = (
            f"dynamic_margin_m {meters:g} is {cells} cells of {resolution:g} m on this map; at "
            f"most {high} cells ({high * resolution:g} m)"
        )
        raise InvalidInput(msg, field="params.dynamic_margin_m")
    return cells

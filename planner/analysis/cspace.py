"""The robot's configuration space on a map in meters (Nav2's inscribed rule, over an exact
distance transform), the metric wall term of ``wide``, and dynamic obstacles given as circles.

>>> from planner.maps.robot_maps import grid_map
>>> m = grid_map([[0, 0, 0, 0, 0], [0, 0, 0, 0, 1]], resolution=0.1)
>>> cs = configuration_space(m, robot_radius=0.15, unknown="free")
>>> cs.traversable.tolist()
[[1, 1, 1, 0, 0], [1, 1, 1, 0, 0]]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.analysis.distance import squared_distances
from planner.errors import InvalidInput, quote
from planner.maps.frames import MapFrame, point_xy
from planner.maps.robot_maps import RobotMap
from planner.params import Unknown

__all__ = ["CSpace", "circle_cells", "configuration_space", "wall_term", "wide_clean"]

#: Shape of the metric wall term: ``(1 - s / wide_distance) ** WIDE_EXPONENT``.
WIDE_EXPONENT = 4.0


@dataclass(frozen=True, eq=False)
class CSpace:
    """A map's configuration space for a round robot.

    ``blocked``: occupied cells (and unknown ones when ``unknown`` is ``"blocked"``);
    ``unknown_cells``: 1 where the map says unknown (-1); ``distance``: from each cell's center
    to the nearest blocked cell's center, in cells (the map's outside counts as blocked when
    ``unknown`` is ``"blocked"``; +inf when nothing is blocked); ``traversable``: free and
    ``distance * resolution > robot_radius``.
    """

    blocked: npt.NDArray[np.uint8]
    distance: npt.NDArray[np.float32]
    traversable: npt.NDArray[np.uint8]
    unknown_cells: npt.NDArray[np.uint8]
    resolution: float
    robot_radius: float
    unknown: Unknown
    occupied_threshold: int

    @property
    def distance_m(self) -> npt.NDArray[np.float64]:
        out: npt.NDArray[np.float64] = self.distance.astype(np.float64) * self.resolution
        return out

    @property
    def margin(self) -> npt.NDArray[np.bool_]:
        """Free cells the robot's center cannot reach: within its radius of a blocked cell."""
        out: npt.NDArray[np.bool_] = (self.blocked == 0) & (self.traversable == 0)
        return out


def configuration_space(
    robot_map: RobotMap,
    *,
    robot_radius: float = 0.0,
    unknown: Unknown = "blocked",
    occupied_threshold: int = 65,
) -> CSpace:
    """The configuration space of a robot of ``robot_radius`` meters on ``robot_map``."""
    if isinstance(robot_radius, bool) or not isinstance(robot_radius, int | float):
        raise InvalidInput(
            f"robot_radius must be a number of meters; got {quote(robot_radius)}",
            field="params.robot_radius",
        )
    if not (math.isfinite(robot_radius) and robot_radius >= 0):
        raise InvalidInput(
            f"robot_radius must be >= 0 meters; got {quote(robot_radius)}",
            field="params.robot_radius",
        )
    if unknown not in ("blocked", "free"):
        raise InvalidInput(
            f"unknown must be 'blocked' or 'free'; got {quote(unknown)}", field="params.unknown"
        )
    occ = robot_map.occupancy
    blocked = occ >= occupied_threshold
    if unknown == "blocked":
        blocked |= occ < 0
    open_ = np.ascontiguousarray(~blocked)
    if blocked.any() or unknown == "blocked":
        squared = squared_distances(open_, outside_blocked=unknown == "blocked")
    else:
        squared = np.full(occ.shape, np.inf)
    # Distances squared are whole numbers of cells squared: compare them, so that a cell exactly
    # at the radius is not traversable whatever the rounding of radius / resolution.
    limit = (robot_radius / robot_map.resolution) ** 2
    traversable = open_ & (squared > limit + 1e-9 * max(1.0, limit))
    np.sqrt(squared, out=squared)  # in place: a 4096 x 4096 map's float64 copy is 128 MB
    arrays = (
        blocked.astype(np.uint8),
        squared.astype(np.float32),
        traversable.astype(np.uint8),
        (occ < 0).astype(np.uint8),
    )
    for arr in arrays:
        arr.flags.writeable = False
    return CSpace(
        blocked=arrays[0],
        distance=arrays[1],
        traversable=arrays[2],
        unknown_cells=arrays[3],
        resolution=robot_map.resolution,
        robot_radius=float(robot_radius),
        unknown=unknown,
        occupied_threshold=int(occupied_threshold),
    )


def wide_clean(cspace: CSpace, *, weight: float, wide_distance: float) -> npt.NDArray[np.float32]:
    """The ``wide`` preset's wall term in meters: for a traversable cell whose clearance beyond
    the robot's radius is ``s = distance_m - robot_radius``,
    ``weight * (1 - s / wide_distance) ** 4`` while ``s < wide_distance``, else 0 (0 on cells
    that are not traversable). Entering a cell pays it on top of the move's length in cells."""
    return wall_term(
        cspace.distance,
        cspace.traversable,
        resolution=cspace.resolution,
        robot_radius=cspace.robot_radius,
        weight=weight,
        wide_distance=wide_distance,
    )


WALL_TERM_BAND = 1 << 18
"""Cells of :func:`wall_term`'s float64 work at a time (2 MB an array)."""


def wall_term(
    distance: npt.NDArray[np.float32],
    traversable: npt.NDArray[np.uint8],
    *,
    resolution: float,
    robot_radius: float,
    weight: float,
    wide_distance: float,
) -> npt.NDArray[np.float32]:
    """:func:`wide_clean` of any window of a configuration space: its ``distance`` (cells) and
    ``traversable`` there. Computed in float64 a band of rows at a time (the same values as
    all at once; a 4096 x 4096 map's float64 temporaries would be 128 MB each)."""
    out = np.empty(distance.shape, dtype=np.float32)
    rows = max(1, WALL_TERM_BAND // max(1, math.prod(distance.shape[1:])))
    for r0 in range(0, distance.shape[0], rows):
        s = distance[r0 : r0 + rows].astype(np.float64) * resolution - robot_radius
        share = (
            np.clip(1.0 - s / wide_distance, 0.0, 1.0) if wide_distance > 0 else np.zeros_like(s)
        )
        out[r0 : r0 + rows] = weight * share**WIDE_EXPONENT
    out[traversable == 0] = 0.0
    return out


def circle_cells(
    robot_map: RobotMap, circles: Any, *, robot_radius: float = 0.0
) -> npt.NDArray[np.int64]:
    """The cells whose centers lie within ``radius + robot_radius`` of a circle's center, for
    circles ``{"x", "y", "radius"}`` in meters (``(n, 2)`` ``[row, col]``, each cell once).

    A circle costs the map rows it spans, whatever its radius: each row's run of covered cells
    is solved for, not searched (a circle of 10**6 m over a 1000 x 1000 map costs 1000 rows,
    not 10**12 cells), and every run is clipped to the map.

    >>> from planner.maps.robot_maps import grid_map
    >>> m = grid_map([[0] * 5] * 5, resolution=0.1)
    >>> circle_cells(m, [{"x": 0.25, "y": 0.25, "radius": 0.12}]).tolist()
    [[1, 2], [2, 1], [2, 2], [2, 3], [3, 2]]
    >>> len(circle_cells(m, [{"x": 0.0, "y": 0.0, "radius": 1e6}]))
    25
    """
    if isinstance(circles, dict) or not isinstance(circles, list | tuple):
        raise InvalidInput(
            f"circles must be a list of {{x, y, radius}}; got {quote(circles)}",
            field="dynamic_obstacles",
        )
    frame = robot_map.frame
    disc = np.empty((len(circles), 3), dtype=np.float64)
    for i, circle in enumerate(circles):
        name = f"dynamic_obstacles[{i}]"
        x, y = point_xy(circle, name=name)
        radius = circle.get("radius") if isinstance(circle, dict) else None
        if (
            isinstance(radius, bool)
            or not isinstance(radius, int | float)
            or not (math.isfinite(radius) and radius >= 0)
        ):
            raise InvalidInput(
                f"{name}.radius must be a number of meters >= 0; got {quote(radius)}",
                field=f"{name}.radius",
            )
        reach = float(radius) + robot_radius
        if _distance_to_map(frame, x, y) > reach:
            raise InvalidInput(
                f"{name} {quote(circle)} is entirely outside the map, even widened by "
                f"robot_radius {robot_radius:g} m: {frame.describe()}",
                field=name,
            )
        disc[i] = x, y, reach
    H, W = frame.shape
    ox, oy, yaw = frame.origin
    cells: npt.NDArray[np.int64] = _circles_cells(
        disc, H, W, frame.resolution, ox, oy, math.cos(yaw), math.sin(yaw)
    )
    return cells


@njit(cache=True, nogil=True)
def _inside(
    r: int, c: int, H: int, res: float, ox: float, oy: float, cos: float, sin: float,
    x: float, y: float, reach: float,
) -> bool:  # fmt: skip
    """Whether cell ``(r, c)``'s center is within ``reach`` of ``(x, y)``: the arithmetic of
    :meth:`MapFrame.centers`, so that a cell on the boundary is decided the same way."""
    u = (c + 0.5) * res
    v = (H - 1 - r + 0.5) * res
    dx = ox + cos * u - sin * v - x
    dy = oy + sin * u + cos * v - y
    return dx**2 + dy**2 <= reach * reach


@njit(cache=True, nogil=True)
def _circle_box(
    x: float, y: float, reach: float, H: int, W: int, res: float, ox: float, oy: float,
    cos: float, sin: float,
) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """A circle's center ``(uc, vc)`` in cells along the map's axes (``c + 0.5`` and
    ``H - r - 0.5`` at a cell's center) and its box of rows and columns, clipped to the map
    (empty when ``lo > hi``); in floats, as the center may lie far outside. The box is a
    square in the map's axes whatever the frame's yaw."""
    du, dv = x - ox, y - oy
    uc = (cos * du + sin * dv) / res
    vc = (-sin * du + cos * dv) / res
    span = reach / res + 2.0
    row = H - 0.5 - vc  # (r + 0.5) = H - v at the center: the center's row, as a float
    return (
        uc,
        vc,
        max(0.0, math.floor(row - span)),
        min(H - 1.0, math.ceil(row + span)),
        max(0.0, math.floor(uc - span)),
        min(W - 1.0, math.ceil(uc + span)),
    )


@njit(cache=True, nogil=True)
def _circles_cells(
    disc: npt.NDArray[np.float64], H: int, W: int, res: float, ox: float, oy: float,
    cos: float, sin: float,
) -> npt.NDArray[np.int64]:  # fmt: skip
    """The cells covered by the circles ``disc`` (``(n, 3)`` ``x, y, reach``), ``(k, 2)`` in
    row-major order: along each row of a circle's box, the run of columns inside (a chord:
    solved for, then its two ends checked exactly) is marked in a difference array over the
    circles' common box; one pass over that box adds the runs up.
    ``O(rows spanned + cells of the box)``, never more than the map's cells."""
    n = disc.shape[0]
    for i in range(n):
        # A circle holding the four corner cells' centers holds every center (both convex):
        # every cell is covered, at the cost of listing them.
        x, y, reach = disc[i, 0], disc[i, 1], disc[i, 2]
        if (
            _inside(0, 0, H, res, ox, oy, cos, sin, x, y, reach)
            and _inside(0, W - 1, H, res, ox, oy, cos, sin, x, y, reach)
            and _inside(H - 1, 0, H, res, ox, oy, cos, sin, x, y, reach)
            and _inside(H - 1, W - 1, H, res, ox, oy, cos, sin, x, y, reach)
        ):
            every = np.empty((H * W, 2), dtype=np.int64)
            for k in range(H * W):
                every[k, 0] = k // W
                every[k, 1] = k % W
            return every
    r0, r1, c0, c1 = H, -1, W, -1
    for i in range(n):
        _, _, lo_r, hi_r, lo_c, hi_c = _circle_box(
            disc[i, 0], disc[i, 1], disc[i, 2], H, W, res, ox, oy, cos, sin
        )
        if lo_r <= hi_r and lo_c <= hi_c:
            r0, r1 = min(r0, int(lo_r)), max(r1, int(hi_r))
            c0, c1 = min(c0, int(lo_c)), max(c1, int(hi_c))
    if r1 < r0 or c1 < c0:
        return np.empty((0, 2), dtype=np.int64)
    runs = np.zeros((r1 - r0 + 1, c1 - c0 + 2), dtype=np.int32)
    for i in range(n):
        x, y, reach = disc[i, 0], disc[i, 1], disc[i, 2]
        uc, vc, lo_r, hi_r, lo_c, hi_c = _circle_box(x, y, reach, H, W, res, ox, oy, cos, sin)
        if lo_r > hi_r or lo_c > hi_c:
            continue
        for r in range(int(lo_r), int(hi_r) + 1):
            # The chord of the circle along row r: columns c with (c + 0.5 - uc)**2 + dv**2
            # <= (reach / res)**2, dv the row's offset from the center in cells.
            dv = (H - r - 0.5) - vc
            half = (reach / res) ** 2 - dv * dv
            root = math.sqrt(half) if half > 0.0 else 0.0
            lo = int(min(max(math.ceil(uc - root - 0.5), lo_c), hi_c + 1.0))
            hi = int(max(min(math.floor(uc + root - 0.5), hi_c), lo_c - 1.0))
            # The ends, exactly: grow while the next cell is in, shrink while an end is out.
            while lo > lo_c and _inside(r, lo - 1, H, res, ox, oy, cos, sin, x, y, reach):
                lo -= 1
            while lo <= hi and not _inside(r, lo, H, res, ox, oy, cos, sin, x, y, reach):
                lo += 1
            while hi < hi_c and _inside(r, hi + 1, H, res, ox, oy, cos, sin, x, y, reach):
                hi += 1
            while hi >= lo and not _inside(r, hi, H, res, ox, oy, cos, sin, x, y, reach):
                hi -= 1
            if lo <= hi:
                runs[r - r0, lo - c0] += 1
                runs[r - r0, hi + 1 - c0] -= 1
    count = 0
    for rr in range(r1 - r0 + 1):
        depth = 0
        for cc in range(c1 - c0 + 1):
            depth += runs[rr, cc]
            count += depth > 0
    out = np.empty((count, 2), dtype=np.int64)
    k = 0
    for rr in range(r1 - r0 + 1):
        depth = 0
        for cc in range(c1 - c0 + 1):
            depth += runs[rr, cc]
            if depth > 0:
                out[k, 0] = r0 + rr
                out[k, 1] = c0 + cc
                k += 1
    return out


def _distance_to_map(frame: MapFrame, x: float, y: float) -> float:
    """Meters from ``(x, y)`` to the nearest point of the map's rectangle (0 inside it)."""
    ox, oy, yaw = frame.origin
    cos, sin = math.cos(yaw), math.sin(yaw)
    u = cos * (x - ox) + sin * (y - oy)
    v = -sin * (x - ox) + cos * (y - oy)
    width, height = frame.shape[1] * frame.resolution, frame.shape[0] * frame.resolution
    return math.hypot(max(-u, 0.0, u - width), max(-v, 0.0, v - height))

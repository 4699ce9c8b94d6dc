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

import edt
import numpy as np
import numpy.typing as npt

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
        squared = edt.edtsq(open_, black_border=unknown == "blocked").astype(np.float64)
    else:
        squared = np.full(occ.shape, np.inf)
    # Distances squared are whole numbers of cells squared: compare them, so that a cell exactly
    # at the radius is not traversable whatever the rounding of radius / resolution.
    limit = (robot_radius / robot_map.resolution) ** 2
    traversable = open_ & (squared > limit + 1e-9 * max(1.0, limit))
    arrays = (
        blocked.astype(np.uint8),
        np.sqrt(squared).astype(np.float32),
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
    ``traversable`` there."""
    s = distance.astype(np.float64) * resolution - robot_radius
    share = np.clip(1.0 - s / wide_distance, 0.0, 1.0) if wide_distance > 0 else np.zeros_like(s)
    out = (weight * share**WIDE_EXPONENT).astype(np.float32)
    out[traversable == 0] = 0.0
    return out


def circle_cells(
    robot_map: RobotMap, circles: Any, *, robot_radius: float = 0.0
) -> npt.NDArray[np.int64]:
    """The cells whose centers lie within ``radius + robot_radius`` of a circle's center, for
    circles ``{"x", "y", "radius"}`` in meters (``(n, 2)`` ``[row, col]``, each cell once).

    >>> from planner.maps.robot_maps import grid_map
    >>> m = grid_map([[0] * 5] * 5, resolution=0.1)
    >>> circle_cells(m, [{"x": 0.25, "y": 0.25, "radius": 0.12}]).tolist()
    [[1, 2], [2, 1], [2, 2], [2, 3], [3, 2]]
    """
    if isinstance(circles, dict) or not isinstance(circles, list | tuple):
        raise InvalidInput(
            f"circles must be a list of {{x, y, radius}}; got {quote(circles)}",
            field="dynamic_obstacles",
        )
    frame = robot_map.frame
    H, W = frame.shape
    res = frame.resolution
    out = np.zeros(frame.shape, dtype=bool)
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
        # The bounding box in cells (a rotated frame's box of the circle is the same square).
        (r0, c0), *_ = frame.cells([[x, y]]).tolist()
        span = math.ceil(reach / res) + 1
        rows = np.arange(max(r0 - span, 0), min(r0 + span + 1, H))
        cols = np.arange(max(c0 - span, 0), min(c0 + span + 1, W))
        if rows.size == 0 or cols.size == 0:
            continue
        rr, cc = np.meshgrid(rows, cols, indexing="ij")
        centers = frame.centers(np.stack([rr.ravel(), cc.ravel()], axis=1))
        inside = (centers[:, 0] - x) ** 2 + (centers[:, 1] - y) ** 2 <= reach * reach
        out[rr.ravel()[inside], cc.ravel()[inside]] = True
    cells: npt.NDArray[np.int64] = np.argwhere(out).astype(np.int64)
    return cells


def _distance_to_map(frame: MapFrame, x: float, y: float) -> float:
    """Meters from ``(x, y)`` to the nearest point of the map's rectangle (0 inside it)."""
    ox, oy, yaw = frame.origin
    cos, sin = math.cos(yaw), math.sin(yaw)
    u = cos * (x - ox) + sin * (y - oy)
    v = -sin * (x - ox) + cos * (y - oy)
    width, height = frame.shape[1] * frame.resolution, frame.shape[0] * frame.resolution
    return math.hypot(max(-u, 0.0, u - width), max(-v, 0.0, v - height))

"""Collision checks of a footprint at poses, and the footprint's clearance, over a map's
blocked cells: numba kernels reading a :class:`~planner.footprint.FootprintCells` table.

Poses here are in the grid's frame, in cells: ``u`` along the columns from the map's left
edge, ``v`` up the rows from its bottom edge, ``theta`` counter-clockwise from the columns'
direction. :class:`Grid` holds a map's arrays as the kernels read them, and converts poses in
meters (the map frame) to that frame and back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.analysis.analyse import Analysis
from planner.errors import InvalidInput
from planner.footprint import FootprintCells
from planner.maps.frames import MapFrame

__all__ = [
    "Grid",
    "clearance_at",
    "densified",
    "densify",
    "footprint_clearance",
    "grid_of",
    "motions_free",
    "pose_free_at",
    "poses_free",
]

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, eq=False)
class Grid:
    """A map as the motion kernels read it: ``blocked`` (1 where a footprint may not hold a
    cell's center), ``distance`` (cells from each cell's center to the nearest blocked cell's
    center), whether the outside of the map counts as blocked, and the map's frame."""

    blocked: npt.NDArray[np.uint8]
    distance: npt.NDArray[np.float32]
    outside_blocked: bool
    frame: MapFrame

    def to_grid(self, poses: Any) -> npt.NDArray[np.float64]:
        """``(n, 3)`` map-frame poses ``[x, y, yaw]`` (meters) as grid poses ``[u, v, theta]``."""
        p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        ox, oy, yaw = self.frame.origin
        dx, dy = p[:, 0] - ox, p[:, 1] - oy
        c, s = math.cos(yaw), math.sin(yaw)
        res = self.frame.resolution
        out = np.stack([(c * dx + s * dy) / res, (-s * dx + c * dy) / res, p[:, 2] - yaw], axis=1)
        return out

    def to_map(self, poses: Any) -> npt.NDArray[np.float64]:
        """Grid poses ``[u, v, theta]`` back in the map frame, yaw wrapped to (-pi, pi]."""
        p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        ox, oy, yaw = self.frame.origin
        c, s = math.cos(yaw), math.sin(yaw)
        res = self.frame.resolution
        u, v = p[:, 0] * res, p[:, 1] * res
        heading = np.angle(np.exp(1j * (p[:, 2] + yaw)))
        out = np.stack([ox + c * u - s * v, oy + s * u + c * v, heading], axis=1)
        return out


def grid_of(analysis: Analysis) -> Grid:
    """The motion kernels' view of a map's analysis (a robot map's: its configuration space
    keeps the map's own blocked cells and distances)."""
    cs = analysis.cspace
    if cs is None:
        msg = "a footprint or a car motion needs a map in meters (an analysis with its frame)"
        raise InvalidInput(msg, field="footprint")
    return Grid(cs.blocked, cs.distance, cs.unknown == "blocked", analysis.frame)


@njit(cache=True, nogil=True)
def pose_free_at(
    blocked: np.ndarray,
    distance: np.ndarray,
    offsets: np.ndarray,
    starts: np.ndarray,
    reach: float,
    outside_blocked: bool,
    u: float,
    v: float,
    theta: float,
) -> bool:
    H, W = blocked.shape
    bins = starts.shape[0] - 1
    col = math.floor(u)
    row = H - 1 - math.floor(v)
    inside = 0 <= row < H and 0 <= col < W
    if inside and distance[row, col] > reach:
        return True  # no blocked cell within any offset's reach
    if not inside and outside_blocked:
        return False
    b = round(theta * bins / (2.0 * math.pi)) % bins
    for i in range(starts[b], starts[b + 1]):
        r = row + offsets[i, 0]
        c = col + offsets[i, 1]
        if 0 <= r < H and 0 <= c < W:
            if blocked[r, c]:
                return False
        elif outside_blocked:
            return False
    return True


@njit(cache=True, nogil=True)
def _poses_free(
    blocked: np.ndarray,
    distance: np.ndarray,
    offsets: np.ndarray,
    starts: np.ndarray,
    reach: float,
    outside_blocked: bool,
    poses: np.ndarray,
) -> np.ndarray:
    out = np.empty(poses.shape[0], dtype=np.bool_)
    for i in range(poses.shape[0]):
        out[i] = pose_free_at(
            blocked, distance, offsets, starts, reach, outside_blocked,
            poses[i, 0], poses[i, 1], poses[i, 2],
        )  # fmt: skip
    return out


@njit(cache=True, nogil=True)
def clearance_at(
    distance: np.ndarray,
    edge: np.ndarray,
    edge_starts: np.ndarray,
    outside_blocked: bool,
    u: float,
    v: float,
    theta: float,
) -> float:
    """Cells from the footprint's outline at a pose to the nearest blocked cell's center: the
    least distance over the outline's cells (0 off the map when the outside is blocked)."""
    H, W = distance.shape
    bins = edge_starts.shape[0] - 1
    col = math.floor(u)
    row = H - 1 - math.floor(v)
    b = round(theta * bins / (2.0 * math.pi)) % bins
    least = np.inf
    for i in range(edge_starts[b], edge_starts[b + 1]):
        r = row + edge[i, 0]
        c = col + edge[i, 1]
        if 0 <= r < H and 0 <= c < W:
            d = distance[r, c]
            if d < least:
                least = d
        elif outside_blocked:
            return 0.0
    return least


@njit(cache=True, nogil=True)
def _clearances(
    distance: np.ndarray,
    edge: np.ndarray,
    edge_starts: np.ndarray,
    outside_blocked: bool,
    poses: np.ndarray,
) -> np.ndarray:
    out = np.empty(poses.shape[0], dtype=np.float64)
    for i in range(poses.shape[0]):
        out[i] = clearance_at(
            distance, edge, edge_starts, outside_blocked, poses[i, 0], poses[i, 1], poses[i, 2]
        )
    return out


def _grid_poses(poses: Any) -> npt.NDArray[np.float64]:
    p = np.ascontiguousarray(np.asarray(poses, dtype=np.float64).reshape(-1, 3))
    if not np.isfinite(p).all():
        raise InvalidInput("poses must be finite [u, v, theta] rows", field="poses")
    return p


def poses_free(grid: Grid, cells: FootprintCells, poses: Any) -> npt.NDArray[np.bool_]:
    """Whether the footprint is free at each grid pose ``[u, v, theta]`` (``(n, 3)``): no
    blocked cell's center in it, judged by the table (conservatively: free for every place in
    the pose's cell and every heading in its bin)."""
    if cells.resolution != grid.frame.resolution:
        msg = (
            f"the footprint's table is for {cells.resolution:g} m cells, the map's are "
            f"{grid.frame.resolution:g} m"
        )
        raise InvalidInput(msg, field="footprint")
    out: npt.NDArray[np.bool_] = _poses_free(
        grid.blocked, grid.distance, cells.offsets, cells.starts, cells.reach,
        grid.outside_blocked, _grid_poses(poses),
    )  # fmt: skip
    return out


def footprint_clearance(grid: Grid, cells: FootprintCells, poses: Any) -> npt.NDArray[np.float64]:
    """Meters from the footprint's outline to the nearest blocked cell's center at each grid
    pose (read on the outline's cells: to within a cell)."""
    out: npt.NDArray[np.float64] = _clearances(
        grid.distance, cells.edge, cells.edge_starts, grid.outside_blocked, _grid_poses(poses)
    )
    return out * grid.frame.resolution


def densify(poses: Any, step: float, angle: float) -> npt.NDArray[np.float64]:
    """Poses ``[u, v, theta]`` with poses put between each two so that none is more than
    ``step`` (in the poses' unit) or ``angle`` radians from the next: the motion between them
    (straight, the heading turned the short way) as the checks see it."""
    return densified(poses, step, angle)[0]


def motions_free(
    grid: Grid, cells: FootprintCells, poses: Any, step: float, angle: float
) -> npt.NDArray[np.bool_]:
    """Whether the footprint is free along the motion from each grid pose to the next
    (``(n - 1,)``), checked as :func:`densify` places the poses between, both ends included."""
    dense, seg = densified(poses, step, angle)
    if len(seg) == 0:
        return np.zeros(0, dtype=np.bool_)
    free = poses_free(grid, cells, dense)
    # Each motion holds its own poses and the first of the next (its end).
    out: npt.NDArray[np.bool_] = np.logical_and.reduceat(free[:-1], np.searchsorted(
        seg, np.arange(seg[-1] + 1)))  # fmt: skip
    out &= free[np.searchsorted(seg, np.arange(1, seg[-1] + 2))]
    return out


def densified(
    poses: Any, step: float, angle: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """:func:`densify`'s poses, and for each but the last the motion it lies on (the index of
    the given pose it leaves from)."""
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    if len(p) < 2:
        return p.copy(), np.zeros(0, dtype=np.int64)
    d = np.diff(p, axis=0)
    turn = np.angle(np.exp(1j * d[:, 2]))
    count = np.maximum(
        np.ceil(np.hypot(d[:, 0], d[:, 1]) / step), np.ceil(np.abs(turn) / angle)
    ).astype(np.int64)
    count = np.maximum(count, 1)
    seg = np.repeat(np.arange(len(d)), count)
    frac = np.concatenate([np.arange(n) / n for n in count])
    out = np.empty((len(seg) + 1, 3))
    out[:-1, :2] = p[seg, :2] + frac[:, None] * d[seg, :2]
    out[:-1, 2] = p[seg, 2] + frac * turn[seg]
    out[-1] = p[-1]
    return out, seg

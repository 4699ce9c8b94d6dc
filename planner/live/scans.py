"""Laser scans on a map: which cells a scan's returns mark and which cells its rays clear, as
Nav2's obstacle layer marks and raytraces, for the live layer every robot of a map shares."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput, quote
from planner.maps.frames import MapFrame

__all__ = ["MAX_RAYS", "LaserScan", "Traced", "trace_rays", "trace_scan"]

MAX_RAYS = 16384
"""Rays one scan holds at most (a 0.1° lidar has 3,600; a 0.025° one 14,400)."""


@dataclass(frozen=True, slots=True)
class LaserScan:
    """A ``sensor_msgs/LaserScan``: ray ``i`` points at ``angle_min + i * angle_increment``
    (radians, from the sensor's heading); ``ranges`` in meters, NaN where no return came."""

    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: npt.NDArray[np.float64]

    def __post_init__(self) -> None:
        n = len(self.ranges)
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            if not math.isfinite(getattr(self, name)):
                msg = f"scan.{name} must be a finite number; got {quote(getattr(self, name))}"
                raise InvalidInput(msg, field=f"scan.{name}")
        if not 0 <= self.range_min < self.range_max:
            msg = (
                f"scan.range_min {quote(self.range_min)} must be at least 0 and less than "
                f"scan.range_max {quote(self.range_max)}"
            )
            raise InvalidInput(msg, field="scan.range_min")
        if not 0 < n <= MAX_RAYS:
            msg = f"scan.ranges holds {n} rays; a scan holds 1 to {MAX_RAYS}"
            raise InvalidInput(msg, field="scan.ranges")
        span = abs(self.angle_increment) * (n - 1)
        if span > 2 * math.pi + 1e-9:
            msg = (
                f"scan spans {span:.6g} radians (angle_increment {quote(self.angle_increment)} "
                f"x {n - 1}); a scan spans at most 2*pi"
            )
            raise InvalidInput(msg, field="scan.angle_increment")
        if np.isinf(self.ranges).any() or (self.ranges < 0).any():
            msg = "scan.ranges must be numbers of at least 0 meters, or null for no return"
            raise InvalidInput(msg, field="scan.ranges")


@dataclass(frozen=True, slots=True)
class Traced:
    """What a scan saw: the ``marked`` cells (flat indices, sorted, none of the map's own
    blocked cells) and the ``cleared`` cells, a mask over the window at ``(top, left)`` (1:
    a ray crossed it and no return marked it)."""

    marked: npt.NDArray[np.int64]
    top: int
    left: int
    cleared: npt.NDArray[np.uint8]


@njit(cache=True, nogil=True)
def _trace(blocked: Any, start: Any, ends: Any, hits: Any) -> tuple[Any, int, int, Any]:
    """The cells the rays from ``start`` (u, v) to ``ends`` (n, 2) cross (grid units: u along
    columns, v up from the map's bottom), each ray's last cell only where ``hits`` is 0, in the
    window of the map round them; and the cells of their ends where ``hits`` (1: a return).
    The returns' cells are marked (the map's blocked cells left out), the rest of every ray
    cleared (the blocked cells left out too), marks winning over clearing. Rays are walked
    cell by cell (Amanatides and Woo) unchecked, on the box round their ends padded by a cell,
    which holds every cell they cross."""
    H, W = blocked.shape
    u0, v0 = start[0], start[1]
    lo_u, hi_u, lo_v, hi_v = u0, u0, v0, v0
    for k in range(ends.shape[0]):
        lo_u, hi_u = min(lo_u, ends[k, 0]), max(hi_u, ends[k, 0])
        lo_v, hi_v = min(lo_v, ends[k, 1]), max(hi_v, ends[k, 1])
    pl, pr = math.floor(lo_u) - 1, math.floor(hi_u) + 1
    pt, pb = H - 2 - math.floor(hi_v), H - math.floor(lo_v)
    pw = pr - pl + 1
    seen = np.zeros((pb - pt + 1) * pw, dtype=np.uint8)
    marks = np.empty(ends.shape[0], dtype=np.int64)
    n = 0
    inf = math.inf
    for k in range(ends.shape[0]):
        u1, v1 = ends[k, 0], ends[k, 1]
        i, j = math.floor(u0), math.floor(v0)
        i1, j1 = math.floor(u1), math.floor(v1)
        du, dv = u1 - u0, v1 - v0
        si = 1 if du > 0 else -1
        sj = 1 if dv > 0 else -1
        tdu = abs(1.0 / du) if du != 0 else inf
        tdv = abs(1.0 / dv) if dv != 0 else inf
        tu = ((i + 1 - u0) / du if du > 0 else (u0 - i) / -du) if du != 0 else inf
        tv = ((j + 1 - v0) / dv if dv > 0 else (v0 - j) / -dv) if dv != 0 else inf
        steps = abs(i1 - i) + abs(j1 - j) + (0 if hits[k] else 1)
        at = (H - 1 - j - pt) * pw + (i - pl)
        for _ in range(steps):
            seen[at] = 1
            if tu < tv:
                tu += tdu
                at += si
            else:
                tv += tdv
                at -= sj * pw
        if hits[k]:
            c, r = i1, H - 1 - j1
            if 0 <= r < H and 0 <= c < W and not blocked[r, c]:
                marks[n] = r * W + c
                n += 1
    marked = np.unique(marks[:n])
    left, right = max(pl, 0), min(pr, W - 1)
    top, bottom = max(pt, 0), min(pb, H - 1)
    cleared = np.zeros((bottom - top + 1, right - left + 1), dtype=np.uint8)
    for r in range(top, bottom + 1):
        base = (r - pt) * pw - pl
        for c in range(left, right + 1):
            if seen[base + c] and not blocked[r, c]:
                cleared[r - top, c - left] = 1
    for m in marked:
        cleared[m // W - top, m % W - left] = 0
    return marked, top, left, cleared


def trace_rays(
    blocked: npt.NDArray[np.bool_],
    start: npt.NDArray[np.float64],
    ends: npt.NDArray[np.float64],
    hits: npt.NDArray[np.bool_],
) -> Traced:
    """Rays on a grid ``blocked`` (H, W) in grid units (``u`` along columns from the left
    edge, ``v`` up from the bottom edge, one cell a unit): from ``start`` (u, v) to ``ends``
    (n, 2), each ending on a return where ``hits``. The cell of a return is marked; every
    other cell a ray crosses is cleared (the map's blocked cells are neither)."""
    if not isinstance(blocked, np.ndarray) or blocked.ndim != 2 or blocked.size == 0:
        msg = f"blocked must be a non-empty 2-D array; got {quote(blocked)}"
        raise InvalidInput(msg, field="blocked")
    start = np.ascontiguousarray(start, dtype=np.float64)
    ends = np.ascontiguousarray(ends, dtype=np.float64).reshape(-1, 2)
    returns = np.ascontiguousarray(hits, dtype=np.uint8).reshape(-1)
    if start.shape != (2,) or len(returns) != len(ends):
        msg = f"start must be (2,) and hits one a ray; got {start.shape} and {len(returns)}"
        raise InvalidInput(msg, field="start")
    if not (np.isfinite(start).all() and np.isfinite(ends).all()):
        raise InvalidInput("rays must have finite ends", field="ends")
    grid = blocked.view(np.uint8) if blocked.dtype == np.bool_ else blocked.astype(np.uint8)
    grid = np.ascontiguousarray(grid)
    marked, top, left, cleared = _trace(grid, start, ends, returns)
    return Traced(marked, int(top), int(left), cleared)


def trace_scan(
    frame: MapFrame,
    blocked: npt.NDArray[np.bool_],
    scan: LaserScan,
    pose: tuple[float, float, float],
    *,
    robot: tuple[float, float] | None = None,
    robot_radius: float = 0.0,
) -> Traced:
    """The cells ``scan`` taken at ``pose`` (x, y, yaw in the map frame) marks and clears on
    a map of ``frame`` whose own ``blocked`` cells are never either. A return in
    ``[range_min, range_max)`` marks its cell and clears the ray before it; a ray with no
    return (or one at ``range_max`` or beyond) clears up to ``range_max``; a return closer
    than ``range_min``, or within ``robot_radius`` of ``robot`` (the robot's own body; by
    default the pose), is ignored, ray and all."""
    x, y, yaw = (float(v) for v in pose)
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        msg = f"scan_pose must be finite x, y and yaw; got {quote(pose)}"
        raise InvalidInput(msg, field="scan_pose")
    if blocked.shape != frame.shape:
        msg = f"blocked must be the map's shape {frame.shape}; got {blocked.shape}"
        raise InvalidInput(msg, field="blocked")
    ranges = scan.ranges
    hits: npt.NDArray[np.bool_] = ~np.isnan(ranges) & (ranges < scan.range_max)
    far = np.where(hits, ranges, scan.range_max)
    angles = yaw + scan.angle_min + scan.angle_increment * np.arange(len(ranges))
    ex, ey = x + far * np.cos(angles), y + far * np.sin(angles)
    rx, ry = robot if robot is not None else (x, y)
    own = np.hypot(ex - rx, ey - ry) < robot_radius
    keep = ~(hits & ((ranges < scan.range_min) | own))
    # Map frame -> grid units: about the origin by -yaw, then in cells.
    ox, oy, oyaw = frame.origin
    cos, sin, res = math.cos(oyaw), math.sin(oyaw), frame.resolution
    px = np.concatenate([[x], ex[keep]]) - ox
    py = np.concatenate([[y], ey[keep]]) - oy
    u, v = (cos * px + sin * py) / res, (-sin * px + cos * py) / res
    # A ray is walked only within the map (and its edge): far ends are cut to it.
    h, w = frame.shape
    if not (0 <= u[0] <= w and 0 <= v[0] <= h):
        msg = f"scan_pose {quote(pose)} is outside the map: a scan is taken on the map"
        raise InvalidInput(msg, field="scan_pose")
    ends = _clip(u[0], v[0], u[1:], v[1:], w, h)
    return trace_rays(blocked, np.array([u[0], v[0]]), ends, hits[keep])


def _clip(
    u0: float, v0: float, u: npt.NDArray[np.float64], v: npt.NDArray[np.float64], w: int, h: int
) -> npt.NDArray[np.float64]:
    """The ends (u, v) pulled back along their rays from (u0, v0) into the box one cell
    round the map, where they leave it: a 100 m ray on a 10 m map walks 10 m."""
    du, dv = u - u0, v - v0
    with np.errstate(divide="ignore", invalid="ignore"):
        tu = np.where(du > 0, (w + 1 - u0) / du, np.where(du < 0, (-1 - u0) / du, np.inf))
        tv = np.where(dv > 0, (h + 1 - v0) / dv, np.where(dv < 0, (-1 - v0) / dv, np.inf))
    t = np.minimum(1.0, np.minimum(tu, tv))
    return np.stack([u0 + t * du, v0 + t * dv], axis=1)

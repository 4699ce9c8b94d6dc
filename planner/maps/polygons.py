"""Polygons in meters on a map: checked (at least three points, finite, simple), the cells whose
centers they hold (a scanline fill), and whether points lie inside them.

A point is inside by the even-odd rule (PNPOLY's crossing test): cells of a polygon's edge are
in or out by the same half-open convention everywhere, so two polygons sharing an edge never
both hold a cell on it.

>>> from planner.maps.frames import MapFrame
>>> square = check_polygon([{"x": 0.1, "y": 0.1}, {"x": 0.3, "y": 0.1},
...                         {"x": 0.3, "y": 0.3}, {"x": 0.1, "y": 0.3}], field="keepout[0]")
>>> polygon_cells(MapFrame((4, 4), 0.1), square).astype(int).tolist()
[[0, 0, 0, 0], [0, 1, 1, 0], [0, 1, 1, 0], [0, 0, 0, 0]]
>>> points_in_polygon([[0.2, 0.2], [0.35, 0.2]], square).tolist()
[True, False]
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput, quote
from planner.maps.frames import MapFrame
from planner.parsing import COORDINATE_MAX, point

__all__ = [
    "COORDINATE_MAX",
    "MAX_POLYGON_POINTS",
    "Polygon",
    "check_polygon",
    "lattice",
    "points_in_polygon",
    "polygon_cells",
]

Polygon = tuple[tuple[float, float], ...]
"""A simple polygon's vertices ``(x, y)`` in meters, in order, not closed (the last vertex is
joined to the first)."""


MAX_POLYGON_POINTS = 1000
"""Vertices a polygon may have at most (its simplicity check compares every pair of edges)."""


def check_polygon(points: Any, *, field: str) -> Polygon:
    """``points`` (``{"x", "y"}`` objects or pairs, meters) as a :data:`Polygon`: at least three,
    at most :data:`MAX_POLYGON_POINTS`, finite, no point repeated next to itself, no edge
    crossing or touching another (a simple polygon: it has an area); else ``InvalidInput``."""
    if isinstance(points, str | bytes | Mapping) or not isinstance(points, Sequence):
        msg = f"{field} must be a list of points {{x, y}}; got {quote(points)}"
        raise InvalidInput(msg, field=field)
    if not 3 <= len(points) <= MAX_POLYGON_POINTS:
        msg = f"{field} must have 3 to {MAX_POLYGON_POINTS} points; got {len(points)}"
        raise InvalidInput(msg, field=field)
    xy: list[tuple[float, float]] = []
    for i, pt in enumerate(points):
        xy.append(point(pt, f"{field}[{i}]"))
    n = len(xy)
    for i in range(n):
        if xy[i] == xy[(i + 1) % n]:
            msg = f"{field}[{(i + 1) % n}] repeats point {i} {quote(points[i])}"
            raise InvalidInput(msg, field=f"{field}[{(i + 1) % n}]")
    arr = np.asarray(xy, dtype=np.float64)
    i, j = _crossing(np.ascontiguousarray(arr[:, 0]), np.ascontiguousarray(arr[:, 1]))
    if i >= 0:
        msg = (
            f"{field} intersects itself: edge {i} (points {i}, {(i + 1) % n}) meets edge {j} "
            f"(points {j}, {(j + 1) % n})"
        )
        raise InvalidInput(msg, field=field)
    return tuple(xy)


@njit(cache=True, nogil=True)
def _orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> int:
    """The sign of the turn a -> b -> c (1: left, -1: right, 0: collinear)."""
    d = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return 1 if d > 0 else (-1 if d < 0 else 0)


@njit(cache=True, nogil=True)
def _on(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> bool:
    """Whether c (collinear with a, b) lies within the box of segment a b."""
    return min(ax, bx) <= cx <= max(ax, bx) and min(ay, by) <= cy <= max(ay, by)


@njit(cache=True, nogil=True)
def _crossing(xs: np.ndarray, ys: np.ndarray) -> tuple[int, int]:
    """The first pair of edges ``(i, j)``, ``i < j`` (edge k from point k to point k + 1), that
    meet where they should not: any common point for edges that are not neighbours, more than
    their shared vertex for neighbours (one folding back along the other); ``(-1, -1)`` for a
    simple polygon."""
    n = xs.size
    for i in range(n - 1):
        px, py, qx, qy = xs[i], ys[i], xs[(i + 1) % n], ys[(i + 1) % n]
        for j in range(i + 1, n):
            cx, cy, dx, dy = xs[j], ys[j], xs[(j + 1) % n], ys[(j + 1) % n]
            o1 = _orient(px, py, qx, qy, cx, cy)
            o2 = _orient(px, py, qx, qy, dx, dy)
            if j == i + 1 or (i == 0 and j == n - 1):
                # Neighbours share a vertex: wrong only when collinear and folding back.
                if o1 == 0 and o2 == 0 and (qx - px) * (dx - cx) + (qy - py) * (dy - cy) < 0:
                    return i, j
                continue
            o3 = _orient(cx, cy, dx, dy, px, py)
            o4 = _orient(cx, cy, dx, dy, qx, qy)
            if o1 * o2 < 0 and o3 * o4 < 0:
                return i, j
            if (
                (o1 == 0 and _on(px, py, qx, qy, cx, cy))
                or (o2 == 0 and _on(px, py, qx, qy, dx, dy))
                or (o3 == 0 and _on(cx, cy, dx, dy, px, py))
                or (o4 == 0 and _on(cx, cy, dx, dy, qx, qy))
            ):
                return i, j
    return -1, -1


def lattice(frame: MapFrame, polygon: Polygon) -> tuple[npt.NDArray[np.float64], ...]:
    """The polygon's vertices in the grid's lattice, where cell ``[r, c]``'s center is at
    ``(c, r)``: ``(cols, rows)``, float arrays."""
    xy = np.asarray(polygon, dtype=np.float64)
    ox, oy, yaw = frame.origin
    dx, dy = xy[:, 0] - ox, xy[:, 1] - oy
    cos, sin = math.cos(yaw), math.sin(yaw)
    u = (cos * dx + sin * dy) / frame.resolution
    v = (-sin * dx + cos * dy) / frame.resolution
    return np.ascontiguousarray(u - 0.5), np.ascontiguousarray(frame.shape[0] - 0.5 - v)


@njit(cache=True, nogil=True)
def _fill(us: np.ndarray, vs: np.ndarray, H: int, W: int) -> np.ndarray:
    """``(H, W)`` bool: the cells whose lattice center ``(c, r)`` the polygon ``(us, vs)``
    holds (even-odd rule): per row, the edges' crossings of the row's center line, sorted,
    filled pairwise."""
    out = np.zeros((H, W), dtype=np.bool_)
    n = us.size
    # Clamped as floats first: a far vertex's lattice coordinate may not fit an integer.
    lo = int(min(max(math.ceil(vs.min()), 0.0), float(H)))
    hi = int(min(max(math.floor(vs.max()), -1.0), float(H - 1)))
    xs = np.empty(n, dtype=np.float64)
    for r in range(lo, hi + 1):
        py = float(r)
        k = 0
        j = n - 1
        for i in range(n):
            yi, yj = vs[i], vs[j]
            # Rows grow downwards where y grows upwards: "<" here is PNPOLY's ">" in meters,
            # so a center on an edge is in or out as the crossing test in meters says.
            if (yi < py) != (yj < py):
                xs[k] = (us[j] - us[i]) * (py - yi) / (yj - yi) + us[i]
                k += 1
            j = i
        row = np.sort(xs[:k])
        for m in range(0, k - 1, 2):
            # Inside: an odd number of crossings right of the center, i.e. row[2m] <= c < row[2m+1].
            c0 = int(min(max(math.ceil(row[m]), 0.0), float(W)))
            c1 = int(min(max(math.ceil(row[m + 1]), 0.0), float(W)))
            for c in range(c0, c1):
                out[r, c] = True
    return out


def polygon_cells(frame: MapFrame, polygon: Polygon) -> npt.NDArray[np.bool_]:
    """``(H, W)`` bool: the cells of ``frame`` whose centers ``polygon`` holds."""
    us, vs = lattice(frame, polygon)
    out: npt.NDArray[np.bool_] = _fill(us, vs, frame.shape[0], frame.shape[1])
    return out


@njit(cache=True, nogil=True)
def _inside(px: np.ndarray, py: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """PNPOLY's crossing test of each point ``(px[k], py[k])`` against the polygon."""
    n = xs.size
    out = np.zeros(px.size, dtype=np.bool_)
    for k in range(px.size):
        x, y = px[k], py[k]
        inside = False
        j = n - 1
        for i in range(n):
            yi, yj = ys[i], ys[j]
            if (yi > y) != (yj > y) and x < (xs[j] - xs[i]) * (y - yi) / (yj - yi) + xs[i]:
                inside = not inside
            j = i
        out[k] = inside
    return out


def points_in_polygon(points: Any, polygon: Polygon) -> npt.NDArray[np.bool_]:
    """Whether each of an ``(n, 2)`` array of ``[x, y]`` points (meters) lies in ``polygon``."""
    xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    poly = np.asarray(polygon, dtype=np.float64)
    out: npt.NDArray[np.bool_] = _inside(
        np.ascontiguousarray(xy[:, 0]),
        np.ascontiguousarray(xy[:, 1]),
        np.ascontiguousarray(poly[:, 0]),
        np.ascontiguousarray(poly[:, 1]),
    )
    return out

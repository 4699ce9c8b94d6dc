"""Straight moves between cell centers, in cells: the cells a segment passes (its supercover)
and exact distances between points and segments. Small numba helpers the roadmap's kernels
share (like :func:`planner.analysis.cells.slide_rows`), each with a checked wrapper.

>>> supercover([0, 0], [1, 2]).tolist()
[[0, 0], [0, 1], [1, 1], [1, 2]]
>>> round(segment_distance([0, 0], [0, 4], [2, 1], [5, 1]), 3)
2.0
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = [
    "point_segment_sq",
    "segment_distance",
    "segment_free",
    "segment_segment_sq",
    "supercover",
]


@njit(cache=True, nogil=True)
def _column_rows(r0: int, c0: int, dr: int, dc: int, c: int, c1: int) -> tuple[int, int]:
    """The rows whose closed squares the segment from ``(r0, c0)`` (``dc > 0`` columns to the
    right, ``dr`` rows down) meets within column ``c``'s closed strip: exact, in integers
    (rows scaled by ``2 * dc``, columns by 2)."""
    xa = max(2 * c - 1, 2 * c0)
    xb = min(2 * c + 1, 2 * c1)
    ya = 2 * dc * r0 + dr * (xa - 2 * c0)
    yb = 2 * dc * r0 + dr * (xb - 2 * c0)
    lo, hi = min(ya, yb), max(ya, yb)
    # row r meets [lo, hi] when 2 dc r - dc <= hi and 2 dc r + dc >= lo
    return -((dc - lo) // (2 * dc)), (hi + dc) // (2 * dc)


@njit(cache=True, nogil=True)
def segment_free(free: npt.NDArray[np.bool_], r0: int, c0: int, r1: int, c1: int) -> bool:
    """Whether every cell whose closed square meets the segment between the centers of
    ``(r0, c0)`` and ``(r1, c1)`` is inside ``free`` and true there."""
    H, W = free.shape
    if c0 > c1:
        r0, c0, r1, c1 = r1, c1, r0, c0
    if c0 < 0 or c1 >= W or min(r0, r1) < 0 or max(r0, r1) >= H:
        return False
    if c0 == c1:
        for r in range(min(r0, r1), max(r0, r1) + 1):  # noqa: SIM110 (numba: no generators)
            if not free[r, c0]:
                return False
        return True
    for c in range(c0, c1 + 1):
        lo, hi = _column_rows(r0, c0, r1 - r0, c1 - c0, c, c1)
        for r in range(lo, hi + 1):
            if not free[r, c]:
                return False
    return True


@njit(cache=True, nogil=True)
def _supercover(r0: int, c0: int, r1: int, c1: int) -> npt.NDArray[np.int64]:
    if c0 > c1:
        r0, c0, r1, c1 = r1, c1, r0, c0
    out = np.empty((2 * (abs(r1 - r0) + c1 - c0) + 4, 2), dtype=np.int64)
    n = 0
    if c0 == c1:
        for r in range(min(r0, r1), max(r0, r1) + 1):
            out[n, 0], out[n, 1] = r, c0
            n += 1
        return out[:n].copy()
    for c in range(c0, c1 + 1):
        lo, hi = _column_rows(r0, c0, r1 - r0, c1 - c0, c, c1)
        for r in range(lo, hi + 1):
            out[n, 0], out[n, 1] = r, c
            n += 1
    return out[:n].copy()


def supercover(start: Any, end: Any) -> npt.NDArray[np.int64]:
    """The cells whose closed squares the segment between the centers of cells ``start`` and
    ``end`` (``[row, col]``) meets, ``(k, 2)`` sorted by column then row: what
    :func:`segment_free` checks."""
    (r0, c0), (r1, c1) = _cell(start, "start"), _cell(end, "end")
    cells: npt.NDArray[np.int64] = _supercover(r0, c0, r1, c1)
    order = np.lexsort((cells[:, 0], cells[:, 1]))
    out: npt.NDArray[np.int64] = cells[order]
    return out


@njit(cache=True, nogil=True)
def point_segment_sq(
    pr: float, pc: float, ar: float, ac: float, br: float, bc: float
) -> float:  # fmt: skip
    """The squared distance from point ``p`` to the segment ``ab``."""
    dr, dc = br - ar, bc - ac
    length = dr * dr + dc * dc
    t = 0.0
    if length > 0.0:
        t = min(1.0, max(0.0, ((pr - ar) * dr + (pc - ac) * dc) / length))
    er, ec = ar + t * dr - pr, ac + t * dc - pc
    return er * er + ec * ec


@njit(cache=True, nogil=True)
def _orient(ar: float, ac: float, br: float, bc: float, pr: float, pc: float) -> float:
    return (br - ar) * (pc - ac) - (bc - ac) * (pr - ar)


@njit(cache=True, nogil=True)
def segment_segment_sq(
    ar: float, ac: float, br: float, bc: float, cr: float, cc: float, dr: float, dc: float
) -> float:  # fmt: skip
    """The squared distance between segments ``ab`` and ``cd``: 0 when they meet, else the
    least of the four endpoint-to-segment distances (exact on whole-cell coordinates, whose
    orientation tests are integers)."""
    o1 = _orient(ar, ac, br, bc, cr, cc)
    o2 = _orient(ar, ac, br, bc, dr, dc)
    o3 = _orient(cr, cc, dr, dc, ar, ac)
    o4 = _orient(cr, cc, dr, dc, br, bc)
    if ((o1 > 0 and o2 < 0) or (o1 < 0 and o2 > 0)) and (
        (o3 > 0 and o4 < 0) or (o3 < 0 and o4 > 0)
    ):
        return 0.0
    return min(
        point_segment_sq(cr, cc, ar, ac, br, bc),
        point_segment_sq(dr, dc, ar, ac, br, bc),
        point_segment_sq(ar, ac, cr, cc, dr, dc),
        point_segment_sq(br, bc, cr, cc, dr, dc),
    )


def segment_distance(a: Any, b: Any, c: Any, d: Any) -> float:
    """The distance between segments ``ab`` and ``cd`` (points ``[row, col]``, in cells)."""
    (ar, ac), (br, bc) = _point(a, "a"), _point(b, "b")
    (cr, cc), (dr, dc) = _point(c, "c"), _point(d, "d")
    return math.sqrt(segment_segment_sq(ar, ac, br, bc, cr, cc, dr, dc))


def _cell(value: Any, name: str) -> tuple[int, int]:
    cell = np.asarray(value)
    if cell.shape != (2,) or not np.issubdtype(cell.dtype, np.integer):
        msg = f"{name}: a [row, col] pair of integers expected; {value!r} given"
        raise ValueError(msg)
    return int(cell[0]), int(cell[1])


def _point(value: Any, name: str) -> tuple[float, float]:
    point = np.asarray(value, dtype=np.float64)
    if point.shape != (2,) or not np.isfinite(point).all():
        msg = f"{name}: a finite [row, col] pair expected; {value!r} given"
        raise ValueError(msg)
    return float(point[0]), float(point[1])

"""Clearance along a polyline, exactly: whether every point of a segment (or of an arc's chords)
is at least a given distance from every blocked cell's center, and the greedy line-of-sight
shortcut that keeps it.

A segment is checked by sphere tracing over the exact distance transform (a cell center's
distance, less the way to it, bounds every nearby point's from below), and, where that bound is
too loose, exactly against the blocked cells near it. Points are (X, Y) in cells, X = col,
Y = -row: a right-handed frame on the map's axes, whose cell centers are whole numbers.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput

__all__ = ["D_REL", "Sight", "chords_clear", "shortcut", "threshold"]

D_REL = 2e-7
"""A relative margin for the rounding of float32 distances."""

_PIECE = 0.5  # cells of a segment checked exactly at once where the lower bound is too loose
_CERTIFY = 0.05  # cells of slack below which a piece is checked exactly
_MARGIN = 0.1  # of the threshold (at least a cell's tenth): what a long segment is checked against
_LONG = 8.0  # cells: shorter segments are checked against the threshold alone
_TIE = 1e-9  # relative: a clearance equal to the bound passes; the radius must be beaten by it
_SQUARE = 0.5  # squared cells: a blocked cell's square lies within half its diagonal of its center
_INSIDE = 1e-9  # cells: a segment along a blocked cell's side or through its corner enters none


class Sight(NamedTuple):
    """What a segment must keep to be clear: every point at least ``root`` = sqrt(``T``) cells
    from every blocked center (the map's outside blocked too when ``outside``), and no cell of
    a mask entered, the mask's corner at (``top``, ``left``)."""

    T: float
    root: float
    outside: bool
    top: int
    left: int


def threshold(least: float, radius: float) -> tuple[float, float]:
    """The bound a path's poses keep (its least clearance ``least`` less one cell) and the
    squared clearance ``T`` every point must keep: more than ``radius`` and than half a cell's
    diagonal, and at least that bound (cells). Ties pass the bound; the radius must be beaten."""
    bound = max(least - 1.0, 0.0) if math.isfinite(least) else 0.0
    T = max(bound * bound * (1.0 - _TIE), radius * radius + _TIE * max(1.0, radius * radius))
    return bound, max(T, _SQUARE + _TIE)


def shortcut(
    distance: npt.NDArray[np.float32],
    polyline: npt.NDArray[np.float64],
    mask: npt.NDArray[np.uint8],
    sight: Sight,
) -> tuple[npt.NDArray[np.int64], int]:
    """The greedy line-of-sight shortcut of ``polyline`` ``(n, 2)`` (cells, X = col, Y = -row)
    over ``distance`` (float32, the exact distance to the nearest blocked center), kept clear
    by ``sight`` and of ``mask`` (uint8, 1: blocked; empty: none): the kept vertices' indices,
    and -1, or the index of a vertex whose step to the next is not clear itself."""
    _check(distance, np.float32, 2, "distance")
    _check(polyline, np.float64, 2, "polyline")
    _check(mask, np.uint8, 2, "mask")
    if polyline.shape[1:] != (2,) or len(polyline) == 0:
        msg = f"polyline must be an (n, 2) array, n >= 1; got shape {polyline.shape!r}"
        raise InvalidInput(msg, field="polyline")
    keep, bad = _shortcut(distance, mask, polyline, _sight(sight))
    return keep, int(bad)


def _sight(sight: Sight) -> Sight:
    """The record with the types its kernels were compiled for."""
    T, root, outside, top, left = sight
    return Sight(float(T), float(root), bool(outside), int(top), int(left))


def _check(array: Any, dtype: type, ndim: int, field: str) -> None:
    if not isinstance(array, np.ndarray) or array.dtype != dtype or array.ndim != ndim:
        got = (
            f"{array.dtype} array of shape {array.shape!r}"
            if isinstance(array, np.ndarray)
            else type(array).__name__
        )
        msg = f"{field} must be a {ndim}-D {np.dtype(dtype)} array; got {got}"
        raise InvalidInput(msg, field=field)
    if not array.flags.c_contiguous:
        raise InvalidInput(f"{field} must be C-contiguous", field=field)


@njit(cache=True, nogil=True)
def _free(mask: Any, top: int, left: int, ax: float, ay: float, bx: float, by: float) -> bool:
    """Whether segment a-b (X = col, Y = -row) enters no blocked cell's square: column by
    column, the rows its part in the column spans."""
    # u, v: the cells' corners at whole numbers, cell (r, c) = [c, c + 1] x [r, r + 1].
    au, av, bu, bv = ax + 0.5, -ay + 0.5, bx + 0.5, -by + 0.5
    h, w = mask.shape
    du, dv = bu - au, bv - av
    u_lo, u_hi = min(au, bu), max(au, bu)
    for c in range(math.floor(u_lo), math.floor(u_hi) + 1):
        u0 = max(u_lo, c + _INSIDE)
        u1 = min(u_hi, c + 1 - _INSIDE)
        if u0 > u1:
            continue
        if abs(du) > 1e-12:
            v0 = av + dv * (u0 - au) / du
            v1 = av + dv * (u1 - au) / du
        else:
            v0, v1 = av, bv
        v_lo, v_hi = min(v0, v1), max(v0, v1)
        cc = c - left
        if cc < 0 or cc >= w:
            continue
        for r in range(math.ceil(v_lo - 1 + _INSIDE), math.floor(v_hi - _INSIDE) + 1):
            rr = r - top
            if 0 <= rr < h and mask[rr, cc]:
                return False
    return True


@njit(cache=True, nogil=True)
def _lower_bound(D: Any, X: float, Y: float) -> float:
    """A lower bound of the distance from (X, Y) to the nearest blocked cell's center: the best
    of the four surrounding centers' exact distance less the way to them."""
    H, W = D.shape
    row = -Y
    r0 = math.floor(row)
    c0 = math.floor(X)
    best = -np.inf
    for r in range(r0, r0 + 2):
        rr = min(max(r, 0), H - 1)
        for c in range(c0, c0 + 2):
            cc = min(max(c, 0), W - 1)
            v = D[rr, cc] * (1.0 - D_REL) - math.hypot(X - cc, row - rr)
            best = max(best, v)
    return best


@njit(cache=True, nogil=True)
def _d2_segment(px: float, py: float, ax: float, ay: float, dx: float, dy: float) -> float:
    """Squared distance from (px, py) to the segment from (ax, ay) along (dx, dy)."""
    L2 = dx * dx + dy * dy
    t = 0.0
    if L2 > 0.0:
        t = min(max(((px - ax) * dx + (py - ay) * dy) / L2, 0.0), 1.0)
    ex = ax + t * dx - px
    ey = ay + t * dy - py
    return ex * ex + ey * ey


@njit(cache=True, nogil=True)
def _piece_clear(
    D: Any, outside: bool, ax: float, ay: float, bx: float, by: float, T: float, inner: float
) -> bool:
    """Whether every point of the short segment a-b is at least sqrt(T) from every blocked
    center, exactly. No blocked center is nearer to a than ``inner``: only the ring between
    ``inner`` and sqrt(T) + |ab| around a is looked at."""
    H, W = D.shape
    dx = bx - ax
    dy = by - ay
    reach = math.sqrt(T) + math.sqrt(dx * dx + dy * dy) + 1e-9
    reach2 = reach * reach
    inner2 = inner * inner if inner > 0.0 else 0.0
    prow = -ay
    for r in range(math.ceil(prow - reach), math.floor(prow + reach) + 1):
        dr = r - prow
        rem = reach2 - dr * dr
        if rem < 0.0:
            continue
        wo = math.sqrt(rem)
        lo = math.ceil(ax - wo)
        hi = math.floor(ax + wo)
        inrem = inner2 - dr * dr
        # Columns strictly within the inner disc hold no blocked center: skip them.
        skip_lo, skip_hi = hi + 1, hi
        if inrem > 0.0:
            wi = math.sqrt(inrem)
            skip_lo = math.floor(ax - wi) + 1
            skip_hi = math.ceil(ax + wi) - 1
        inside_row = 0 <= r < H
        c = lo
        while c <= hi:
            if skip_lo <= c <= skip_hi:
                c = skip_hi + 1
                continue
            is_blocked = D[r, c] == 0.0 if inside_row and 0 <= c < W else outside
            if is_blocked and _d2_segment(float(c), -float(r), ax, ay, dx, dy) < T:
                return False
            c += 1
    return True


@njit(cache=True, nogil=True)
def _segment_clear(
    D: Any, outside: bool, ax: float, ay: float, bx: float, by: float, T: float, root: float
) -> bool:
    """Whether every point of segment a-b is at least sqrt(T) = ``root`` from every blocked
    center: sphere tracing over the lower bound, exact pieces where it is too loose."""
    dx = bx - ax
    dy = by - ay
    L = math.hypot(dx, dy)
    ux = dx / L if L > 0.0 else 0.0
    uy = dy / L if L > 0.0 else 0.0
    s = 0.0
    while True:
        px = ax + ux * s
        py = ay + uy * s
        lb = _lower_bound(D, px, py)
        slack = lb - root - 1e-9
        if slack > _CERTIFY:
            # Every point within `slack` of p is clear.
            s += slack
            if s >= L:
                return True
        else:
            s1 = min(s + _PIECE, L)
            qx = bx if s1 >= L else ax + ux * s1
            qy = by if s1 >= L else ay + uy * s1
            if not _piece_clear(D, outside, px, py, qx, qy, T, lb):
                return False
            if s1 >= L:
                return True
            s = s1


@njit(cache=True, nogil=True)
def _step_bound(D: Any, x0: float, y0: float, x1: float, y1: float) -> float:
    """A lower bound of the clearance along segment 0-1 from its ends' lower bounds alone: a
    blocked center at least m from both ends is at least sqrt(m^2 - |01|^2 / 4) from every point
    between them."""
    m = min(_lower_bound(D, x0, y0), _lower_bound(D, x1, y1))
    q = ((x1 - x0) ** 2 + (y1 - y0) ** 2) / 4.0
    return math.sqrt(m * m - q) if m > 0.0 and m * m > q else -np.inf


@njit(cache=True, nogil=True)
def _shortcut(D: Any, mask: Any, V: Any, sight: Sight) -> tuple[Any, int]:
    """The greedy line-of-sight shortcut of the polyline V: from each kept vertex, the next
    kept one is the last before the first vertex it cannot see clear (nor enter a cell of
    ``mask``, whose corner is (top, left); an empty mask blocks none). Returns the kept indices,
    and -1, or the index of a vertex whose step to the next is not clear itself.

    A certified lower bound ``cert`` of the clearance along the segment seen so far saves most
    checks of long segments: segment a-c lies within h (the distance from b to the line a-c) of
    a-b and b-c, and clearance changes no faster than the way moved, so a-c keeps at least
    min(cert(a-b), bound(b-c)) - h. Where that is not enough, a long segment is checked exactly
    against a margin above the threshold, which the next steps then spend (a failed margin is
    tried again only at twice the length): linear, not quadratic, along long corridors."""
    T, root, outside, top, left = sight
    n = V.shape[0]
    keep = np.empty(n, dtype=np.int64)
    keep[0] = 0
    k = 1
    a = 0
    margin = _MARGIN * max(root, 1.0)
    wide2 = (root + margin) * (root + margin)
    masked = mask.shape[0] > 0
    while a < n - 1:
        ax, ay = V[a, 0], V[a, 1]
        j = a + 1
        if not _segment_clear(D, outside, ax, ay, V[j, 0], V[j, 1], T, root) or (
            masked and not _free(mask, top, left, ax, ay, V[j, 0], V[j, 1])
        ):
            return keep[:k], a
        cert = max(root, _step_bound(D, ax, ay, V[j, 0], V[j, 1]))
        retry = 0.0  # segments shorter than this are not tried against the margin
        while j + 1 < n:
            bx, by, cx, cy = V[j, 0], V[j, 1], V[j + 1, 0], V[j + 1, 1]
            ux, uy = bx - ax, by - ay
            vx, vy = cx - bx, cy - by
            straight = ux * vy - uy * vx == 0.0 and ux * vx + uy * vy > 0.0
            if straight:
                # Straight on: the segment seen so far and one more step.
                ok = _segment_clear(D, outside, bx, by, cx, cy, T, root)
                cert = min(cert, max(root, _step_bound(D, bx, by, cx, cy)))
            else:
                wx, wy = cx - ax, cy - ay
                L = math.hypot(wx, wy)
                h = abs(ux * wy - uy * wx) / L if L > 0.0 else np.inf
                bound = min(cert, _step_bound(D, bx, by, cx, cy)) - h
                if bound > root + 1e-9:
                    ok = True
                    cert = bound
                elif retry <= L and L > _LONG:
                    ok = _segment_clear(D, outside, ax, ay, cx, cy, wide2, root + margin)
                    cert = root + margin
                    if not ok:
                        retry = 2.0 * L
                        ok = _segment_clear(D, outside, ax, ay, cx, cy, T, root)
                        cert = root
                else:
                    ok = _segment_clear(D, outside, ax, ay, cx, cy, T, root)
                    cert = root
            if ok and masked:  # straight on, b-c is a-c's last piece
                ok = (
                    _free(mask, top, left, bx, by, cx, cy)
                    if straight
                    else _free(mask, top, left, ax, ay, cx, cy)
                )
            if not ok:
                break
            j += 1
        keep[k] = j
        k += 1
        a = j
    return keep[:k], -1


@njit(cache=True, nogil=True)
def _upper_bound(D: Any, X: float, Y: float) -> float:
    """An upper bound of the distance from (X, Y) to the nearest blocked cell's center: the
    nearest surrounding center's exact distance plus the way to it."""
    H, W = D.shape
    rr = min(max(round(-Y), 0), H - 1)
    cc = min(max(round(X), 0), W - 1)
    return float(D[rr, cc]) * (1.0 + D_REL) + math.hypot(X - cc, -Y - rr)


@njit(cache=True, nogil=True)
def chords_clear(D: Any, mask: Any, pts: Any, sight: Sight) -> bool:
    """Whether every chord of an arc's points ``pts`` keeps ``sight`` (as :func:`shortcut`);
    an arc with a point surely too near (the bisection of a corner tries many) is refused
    before any exact check. A kernel: the corners' rounding calls it in its loop, with the
    arrays :func:`shortcut` checks."""
    T, root, outside, top, left = sight
    for q in range(pts.shape[0]):
        if _upper_bound(D, pts[q, 0], pts[q, 1]) < root - 1e-9:
            return False
    if mask.shape[0] > 0:
        for q in range(pts.shape[0] - 1):
            if not _free(mask, top, left, pts[q, 0], pts[q, 1], pts[q + 1, 0], pts[q + 1, 1]):
                return False
    for q in range(pts.shape[0] - 1):
        if not _segment_clear(
            D, outside, pts[q, 0], pts[q, 1], pts[q + 1, 0], pts[q + 1, 1], T, root
        ):
            return False
    return True

"""The cells a step's dynamic obstacles block, for the path ahead: a small window's mask of them
(each obstacle's cell and those within the margin), how far along a route the robot reaches
before one, and whether a segment enters one's square."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["reachable"]

_INSIDE = 1e-9  # cells: a segment along a blocked cell's side or through its corner enters none


@njit(cache=True, nogil=True)
def _window(
    obstacles: Any, margin: int, top: int, left: int, h: int, w: int, route: Any, exempt: int
) -> Any:
    """The cells within Chebyshev ``margin`` of an obstacle, in the h x w window at (top,
    left) (1: blocked), less the route's first ``exempt`` cells (where the robot is, and the
    cell this step moves it to: the decision already took that move)."""
    mask = np.zeros((h, w), dtype=np.uint8)
    for j in range(obstacles.shape[0]):
        r0 = max(obstacles[j, 0] - margin - top, 0)
        r1 = min(obstacles[j, 0] + margin - top, h - 1)
        c0 = max(obstacles[j, 1] - margin - left, 0)
        c1 = min(obstacles[j, 1] + margin - left, w - 1)
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                mask[r, c] = 1
    for i in range(min(exempt, route.shape[0])):
        mask[route[i, 0] - top, route[i, 1] - left] = 0
    return mask


@njit(cache=True, nogil=True)
def _clear_prefix(route: Any, mask: Any, top: int, left: int, exempt: int) -> int:
    """How many of the route's cells the robot reaches before a move into a blocked cell, or a
    diagonal one past a blocked cell beside it (as a decision refuses), after the first
    ``exempt`` moves; and before a cell it reached already (a walk that loops)."""
    n: int = route.shape[0]
    seen = np.zeros(mask.shape, dtype=np.uint8)
    for i in range(n):
        r, c = route[i, 0] - top, route[i, 1] - left
        if seen[r, c]:
            return i
        seen[r, c] = 1
        if i == 0 or i <= exempt:
            continue
        pr, pc = route[i - 1, 0] - top, route[i - 1, 1] - left
        if mask[r, c] or (r != pr and c != pc and (mask[pr, c] or mask[r, pc])):
            return i
    return n


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
def _reach(
    flat: Any, W: int, H: int, obstacles: Any, margin: int, exempt: int
) -> tuple[Any, int, Any, int, int]:
    """The route's cells (from flat indices), how many the robot reaches clear of the blocked
    cells (:func:`_clear_prefix`), and the window's mask and corner."""
    m = flat.shape[0]
    route = np.empty((m, 2), dtype=np.int64)
    top, left, bottom, right = H, W, 0, 0
    for i in range(m):
        r = flat[i] // W
        c = flat[i] - r * W
        route[i, 0], route[i, 1] = r, c
        top, left = min(top, r), min(left, c)
        bottom, right = max(bottom, r), max(right, c)
    top, left = max(top - 1, 0), max(left - 1, 0)
    h, w = min(bottom + 2, H) - top, min(right + 2, W) - left
    mask = _window(obstacles, margin, top, left, h, w, route, exempt + 1)
    n = _clear_prefix(route, mask, top, left, exempt)
    return route, n, mask, top, left


def reachable(
    route: npt.NDArray[np.int64],
    shape: tuple[int, int],
    obstacles: npt.NDArray[np.int64],
    *,
    margin: int,
    exempt: int,
) -> int:
    """How many of ``route``'s cells (flat indices of a map of ``shape``) the robot reaches
    before a move into a cell within Chebyshev ``margin`` of one of the ``obstacles`` (or
    diagonally past one), after the first ``exempt`` moves: those :func:`poses_ahead` follows."""
    return int(_reach(route, shape[1], shape[0], obstacles, margin, exempt)[1])

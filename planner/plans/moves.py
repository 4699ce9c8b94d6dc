"""The eight moves (numbered clockwise from north: N NE E SE S SW W NW), which cells a wave's
grid holds, and the octile distance: what the waves, the detour and the decision share."""

from __future__ import annotations

import numpy as np
from numba import njit

from planner.analysis.cells import FREE, TUNNEL

__all__ = ["DC", "DR", "OPEN_PASSABLE", "OPEN_SEALED", "OPEN_UNSEALED", "octile", "on_grid"]

DR = np.array([-1, -1, 0, 1, 1, 1, 0, -1], dtype=np.int64)
DC = np.array([0, 1, 1, 1, 0, -1, -1, -1], dtype=np.int64)

# A wave's grid is an array of cell codes and an ``open`` bit mask: cell (r, c) is on the grid
# when bit ``codes[r, c]`` of ``open`` is set (the goal always is). Cells are flat ``r * W + c``.
#: Over an analysis's cell states: the sealed grid (free cells) and the unsealed one (tunnels too).
OPEN_SEALED = 1 << FREE
OPEN_UNSEALED = (1 << FREE) | (1 << TUNNEL)
#: Over a 0/1 ``passable`` array (1 where passable).
OPEN_PASSABLE = 1 << 1


@njit(cache=True, nogil=True)
def on_grid(codes: np.ndarray, open_: int, goal: int, r: int, c: int) -> bool:
    """Whether (r, c) is on the grid: inside the map, and its code open (or the goal)."""
    H, W = codes.shape
    if r < 0 or r >= H or c < 0 or c >= W:
        return False
    if r * W + c == goal:
        return True
    return bool((open_ >> codes[r, c]) & 1)


@njit(cache=True, nogil=True)
def octile(r: int, c: int, tr: int, tc: int, diagonal_cost: float, slack: float) -> float:
    """``max(0, octile((r, c), (tr, tc)) - slack)``: a consistent lower bound of the cost from
    (r, c) to any cell within octile distance ``slack`` of (tr, tc)."""
    dr = abs(r - tr)
    dc = abs(c - tc)
    lo = min(dr, dc)
    hi = max(dr, dc)
    v = (hi - lo) + diagonal_cost * lo - slack
    return v if v > 0.0 else 0.0

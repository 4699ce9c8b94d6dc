"""Cell states of an analysed map (docs/algorithm.md, "World model"): free, blocked, tight tunnel;
and the gates,
the zero-width diagonal gaps, counted and listed."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["BLOCKED_CELL", "FREE", "TUNNEL", "classify", "gate_cells", "slide_rows"]

FREE = 0
BLOCKED_CELL = 1  # a static obstacle: "blocked" as in the API
TUNNEL = 2  # a tight-tunnel cell: free, but sealed when ``seal_tunnels`` is on


def _grid(grid: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    if not isinstance(grid, np.ndarray) or grid.dtype != np.uint8 or grid.ndim != 2:
        got = (
            f"{grid.dtype} array of shape {grid.shape!r}"
            if isinstance(grid, np.ndarray)
            else type(grid).__name__
        )
        msg = f"grid must be a 2-D uint8 array of 0 and 1; {got} given."
        raise TypeError(msg)
    return np.ascontiguousarray(grid)


@njit(cache=True, nogil=True)
def slide_rows(
    pad: np.ndarray, grid: np.ndarray, r: int, outside: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre ``pad`` (3 rows of W + 2 cells, filled with ``outside`` by the caller) on map row r:
    rows r - 1, r and r + 1 of ``grid != 0``, shifted one column, ``outside`` beyond the map.
    Called for r = 0, 1, ... in turn, it reads each row of the map once; returns the three rows."""
    H, W = grid.shape
    if r == 0:
        for c in range(W):
            pad[2, c + 1] = 1 if grid[0, c] != 0 else 0
    for c in range(W + 2):
        pad[0, c] = pad[1, c]
        pad[1, c] = pad[2, c]
    if r + 1 < H:
        for c in range(W):
            pad[2, c + 1] = 1 if grid[r + 1, c] != 0 else 0
    else:
        for c in range(W + 2):
            pad[2, c] = outside
    return pad[0], pad[1], pad[2]


@njit(cache=True, nogil=True)
def _classify(grid: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Cell states (FREE, BLOCKED_CELL, TUNNEL), the gate count and the tunnel count, row by row
    over padded copies of three rows (the outside blocked), every inner loop branch-free."""
    H, W = grid.shape
    state = np.empty((H, W), dtype=np.uint8)
    pad = np.ones((3, W + 2), dtype=np.uint8)  # blocked: rows r - 1, r, r + 1
    tunnels = 0
    gates = 0
    for r in range(H):
        up, mid, down = slide_rows(pad, grid, r, 1)
        for c in range(W):
            blocked = mid[c + 1]
            tunnel = (up[c + 1] & down[c + 1]) | (mid[c] & mid[c + 2])
            tunnel &= 1 - blocked
            state[r, c] = blocked * BLOCKED_CELL + tunnel * TUNNEL
            tunnels += tunnel
        if r + 1 < H:
            # A gate: two free cells diagonal to each other, the other two of the square blocked.
            for c in range(W - 1):
                a = mid[c + 1]
                b = mid[c + 2]
                d = down[c + 1]
                e = down[c + 2]
                gates += ((1 - a) & (1 - e) & b & d) | ((1 - b) & (1 - d) & a & e)
    return state, gates, tunnels


def classify(grid: npt.NDArray[np.uint8]) -> tuple[npt.NDArray[np.uint8], int, int]:
    """Cell states (``FREE``, ``BLOCKED_CELL``, ``TUNNEL``) of a 0/1 grid, its gate count and its
    tunnel count (the outside counts as blocked).

    >>> state, gates, tunnels = classify(np.array([[0, 1], [1, 0]], dtype=np.uint8))
    >>> state.tolist(), gates, tunnels
    ([[2, 1], [1, 2]], 1, 2)
    """
    state, gates, tunnels = _classify(_grid(grid))
    return state, int(gates), int(tunnels)


@njit(cache=True, nogil=True)
def _gate_cells(grid: np.ndarray) -> np.ndarray:
    """Every gate as a row ``[r1, c1, r2, c2]``: the two free cells of the diagonal gap."""
    H, W = grid.shape
    out = np.empty((max(H - 1, 0) * max(W - 1, 0), 4), dtype=np.int64)
    n = 0
    for r in range(H - 1):
        for c in range(W - 1):
            a = grid[r, c] == 0
            b = grid[r, c + 1] == 0
            d = grid[r + 1, c] == 0
            e = grid[r + 1, c + 1] == 0
            if a and e and not b and not d:
                out[n, 0], out[n, 1], out[n, 2], out[n, 3] = r, c, r + 1, c + 1
                n += 1
            elif b and d and not a and not e:
                out[n, 0], out[n, 1], out[n, 2], out[n, 3] = r, c + 1, r + 1, c
                n += 1
    return out[:n].copy()


def gate_cells(grid: npt.NDArray[np.uint8]) -> npt.NDArray[np.int64]:
    """Every gate of a 0/1 grid as a row ``[r1, c1, r2, c2]``: the two free cells of the gap."""
    out: npt.NDArray[np.int64] = _gate_cells(_grid(grid))
    return out

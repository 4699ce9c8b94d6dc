"""The ``clean`` field (docs/algorithm.md, "World model"): the penalty of a cell for the blocked
cells around it,
the paper's new class parameter generalised to a radius."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.analysis.cells import BLOCKED_CELL, TUNNEL

__all__ = ["clean_field"]


@njit(cache=True, nogil=True)
def _clean(state: np.ndarray, seal: bool, weight: float, radius: int) -> np.ndarray:
    """The clean penalty of every non-obstacle cell: each blocked cell (an obstacle, a sealed
    tunnel cell, or outside the map) at Chebyshev distance d, 1 <= d <= radius, adds
    ``weight / d``.

    Separable box sums over a ring of 2 * radius + 1 rows: per ring distance d, each row's sums
    over 2d + 1 columns, then their sums over 2d + 1 rows; every inner loop runs along a row (the
    compiler vectorises it) and the working set is a few rows, not the whole map.
    """
    H, W = state.shape
    p = radius
    ring = 2 * p + 1
    Wp = W + 2 * p
    blocked = np.ones((ring, Wp), dtype=np.int16)  # padded rows; the outside counts as blocked
    rows = np.empty((radius + 1, ring, W), dtype=np.int16)  # rows[d]: sums over 2d + 1 columns
    box = np.empty(W, dtype=np.int16)
    inner = np.empty(W, dtype=np.int16)
    total = np.empty(W, dtype=np.float64)
    out = np.zeros((H, W), dtype=np.float32)
    for i in range(H + 2 * p):  # padded row i is map row i - p
        slot = i % ring
        r = i - p
        if 0 <= r < H:
            for c in range(W):
                s = state[r, c]
                blocked[slot, c + p] = 1 if (s == BLOCKED_CELL or (seal and s == TUNNEL)) else 0
        else:
            for c in range(Wp):
                blocked[slot, c] = 1
        for c in range(W):
            rows[0, slot, c] = blocked[slot, c + p]
        for d in range(1, radius + 1):
            for c in range(W):
                rows[d, slot, c] = rows[d - 1, slot, c] + blocked[slot, c + p - d]
                rows[d, slot, c] += blocked[slot, c + p + d]
        r = i - 2 * p  # the map row whose window (rows r - p .. r + p) is now complete
        if r < 0:
            continue
        centre = (r + p) % ring
        for c in range(W):
            inner[c] = rows[0, centre, c]
            total[c] = 0.0
        for d in range(1, radius + 1):
            for c in range(W):
                box[c] = rows[d, (r + p - d) % ring, c]
            for k in range(r + p - d + 1, r + p + d + 1):
                slot_k = k % ring
                for c in range(W):
                    box[c] += rows[d, slot_k, c]
            for c in range(W):
                total[c] += (box[c] - inner[c]) / d
                inner[c] = box[c]
        for c in range(W):
            if state[r, c] != BLOCKED_CELL:
                out[r, c] = weight * total[c]
    return out


def clean_field(
    state: npt.NDArray[np.uint8], *, seal: bool, weight: float, radius: int
) -> npt.NDArray[np.float32]:
    """The clean penalty of every cell of an analysed map's ``state`` (0 on obstacles), the
    tunnel cells counted as blocked when ``seal``.

    >>> state = np.array([[0, 0, 0], [0, 1, 0]], dtype=np.uint8)
    >>> clean_field(state, seal=True, weight=0.5, radius=1).tolist()
    [[3.0, 2.0, 3.0], [3.0, 0.0, 3.0]]
    """
    if not isinstance(state, np.ndarray) or state.dtype != np.uint8 or state.ndim != 2:
        msg = f"state must be a 2-D uint8 array of cell states; {state!r:.60} given."
        raise TypeError(msg)
    if radius < 1:
        msg = f"radius must be at least 1; {radius!r} given."
        raise ValueError(msg)
    out: npt.NDArray[np.float32] = _clean(
        np.ascontiguousarray(state), bool(seal), float(weight), int(radius)
    )
    return out

"""The exact Euclidean distance transform: from every free cell's center to the nearest blocked
cell's center, squared, in cells. Felzenszwalb and Huttenlocher's two passes (a distance down
each column, then the lower envelope of parabolas along each row), in a ``nogil`` kernel, so
that a map's analysis on a worker thread leaves the event loop its turns.

>>> import numpy as np
>>> free = np.ones((3, 4), dtype=bool)
>>> free[1, 1] = False
>>> squared_distances(free, outside_blocked=False)
array([[2., 1., 2., 5.],
       [1., 0., 1., 4.],
       [2., 1., 2., 5.]])
>>> squared_distances(free, outside_blocked=True)
array([[1., 1., 1., 1.],
       [1., 0., 1., 1.],
       [1., 1., 1., 1.]])
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput

__all__ = ["squared_distances"]


def squared_distances(
    free: npt.NDArray[np.bool_], *, outside_blocked: bool
) -> npt.NDArray[np.float64]:
    """For every cell of the 2-D boolean ``free``, the squared distance (in cells, a whole
    number) from its center to the nearest center of a cell that is not free; 0 on those cells.
    With ``outside_blocked`` the ring of cells just outside the array counts as blocked;
    without it, and with no blocked cell at all, every distance is infinite."""
    free = np.asarray(free)
    if free.ndim != 2 or free.dtype != np.bool_:
        msg = (
            "free must be a 2-D array of booleans (True where free); "
            f"got a {free.ndim}-D array of {free.dtype}"
        )
        raise InvalidInput(msg, field="free")
    out = np.empty(free.shape, dtype=np.float64)
    # One layout for the kernel (numba compiles apart for read-only arrays).
    free = np.require(free, requirements=["C_CONTIGUOUS", "WRITEABLE"])
    _squared_distances(free, bool(outside_blocked), out)
    return out


@njit(cache=True, nogil=True)
def _squared_distances(
    free: npt.NDArray[np.bool_], outside_blocked: bool, out: npt.NDArray[np.float64]
) -> None:
    H, W = free.shape
    edge = 1.0 if outside_blocked else np.inf
    # Down each column, a whole row at a time (the array's own order): the distance to the
    # nearest blocked cell above, then below.
    for c in range(W):
        out[0, c] = edge if free[0, c] else 0.0
    for r in range(1, H):
        for c in range(W):
            out[r, c] = out[r - 1, c] + 1.0 if free[r, c] else 0.0
    for c in range(W):
        out[H - 1, c] = min(out[H - 1, c], edge)
    for r in range(H - 2, -1, -1):
        for c in range(W):
            out[r, c] = min(out[r, c], out[r + 1, c] + 1.0)
    f = np.empty(W, dtype=np.float64)
    v = np.empty(W, dtype=np.int64)
    z = np.empty(W + 1, dtype=np.float64)
    for r in range(H):
        for c in range(W):
            f[c] = out[r, c] * out[r, c]
        _row(f, v, z, outside_blocked, out[r])


@njit(cache=True, nogil=True)
def _row(
    f: npt.NDArray[np.float64],
    v: npt.NDArray[np.int64],
    z: npt.NDArray[np.float64],
    outside_blocked: bool,
    out: npt.NDArray[np.float64],
) -> None:
    """Along one row: ``out[q] = min over p of (q - p)^2 + f[p]``, the parabolas of the finite
    ``f[p]`` kept in ``v`` in order and ``z`` holding where each one starts to be the lowest."""
    W = f.size
    k = -1
    for q in range(W):
        if f[q] == np.inf:
            continue
        if k < 0:
            k = 0
            v[0] = q
            z[0] = -np.inf
            z[1] = np.inf
            continue
        s = 0.0
        while True:
            p = v[k]
            s = ((f[q] + q * q) - (f[p] + p * p)) / (2.0 * (q - p))
            if s > z[k]:
                break
            k -= 1  # z[0] is -inf, so k stays >= 0
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = np.inf
    j = 0
    for q in range(W):
        if k < 0:
            d = np.inf
        else:
            while z[j + 1] < q:
                j += 1
            p = v[j]
            d = (q - p) * (q - p) + f[p]
        if outside_blocked:
            d = min(d, (q + 1.0) * (q + 1.0), (W - q) * (W - q) * 1.0)
        out[q] = d

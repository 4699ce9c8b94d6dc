"""The medial axis of free space: the cells equally far from two sides, as a thin connected
skeleton (scikit-image's ``medial_axis`` algorithm, over the exact distance transform the
configuration space already has, with its lookup table built once).

>>> import numpy as np
>>> from scipy import ndimage
>>> free = np.zeros((5, 9), dtype=bool)
>>> free[1:4, 1:8] = True  # a 3 x 7 room: its middle row, and a spur into each corner
>>> medial_axis(free, ndimage.distance_transform_edt(free)).astype(int)[1:4, 1:8]
array([[1, 0, 0, 0, 0, 0, 1],
       [0, 1, 1, 1, 1, 1, 0],
       [1, 0, 0, 0, 0, 0, 1]])
"""

from __future__ import annotations

from functools import cache

import numpy as np
import numpy.typing as npt
from numba import njit
from scipy import ndimage

from planner.errors import InvalidInput

__all__ = ["medial_axis"]


def medial_axis(
    free: npt.NDArray[np.bool_], distance: npt.NDArray[np.floating]
) -> npt.NDArray[np.bool_]:
    """The medial axis of the ``free`` cells (True), given each cell's ``distance`` to the
    nearest blocked cell's center (in cells; the outside of the array counts as blocked).

    Free cells are removed in order of increasing distance (then the more "cornery" first, then
    a fixed pseudo-random order: scikit-image's, seeded 0), each unless removing it would split
    its 3 x 3 neighbourhood or it has fewer than two neighbours: what is left is the skeleton,
    one cell thin, connected as the free space is. The same cells as
    ``skimage.morphology.medial_axis(free, rng=0)`` on ``free`` padded with a blocked ring.
    """
    if free.shape != distance.shape or free.ndim != 2:
        msg = f"free and distance must be 2-D of one shape; got {free.shape} and {distance.shape}"
        raise InvalidInput(msg, field="free")
    free = np.asarray(free, dtype=bool)
    counts = ndimage.correlate(free.astype(np.uint8), np.ones((3, 3), np.uint8), mode="constant")
    flat = np.flatnonzero(free)
    keys = np.random.default_rng(0).permutation(flat.size)  # the tiebreak, then the keys
    _keys(keys, flat, np.ravel(distance), counts.ravel())
    order = np.argsort(keys)  # the keys are unique (the tiebreak is): any sort agrees
    del keys
    _gather(order, flat)
    del flat
    result = free.astype(np.uint8)
    _thin(result, order, _table())
    out: npt.NDArray[np.bool_] = result.astype(bool)
    return out


@njit(cache=True, nogil=True)
def _keys(
    keys: npt.NDArray[np.int64],
    flat: npt.NDArray[np.int64],
    distance: npt.NDArray[np.floating],
    counts: npt.NDArray[np.uint8],
) -> None:
    """Each free cell's (``flat``) sort key, one integer, written over its tiebreak in
    ``keys``: squared distance (whole cells squared), then cornerness (9 minus its 3 x 3
    count), then the tiebreak. In place, not as numpy expressions: each of those would be
    another 8 bytes a free cell (2 M cells of a 2048 x 2048 map: 34 MB each)."""
    n = max(keys.size, 1)
    for i in range(keys.size):
        d = np.float64(distance[flat[i]])
        squared = np.int64(np.rint(d * d))
        keys[i] = (squared * 9 + (9 - np.int64(counts[flat[i]]))) * n + keys[i]


@njit(cache=True, nogil=True)
def _gather(order: npt.NDArray[np.int64], flat: npt.NDArray[np.int64]) -> None:
    """``order[i] = flat[order[i]]``, in place: the cells in the order sorted."""
    for i in range(order.size):
        order[i] = flat[order[i]]


@cache
def _table() -> npt.NDArray[np.uint8]:
    """For each 3 x 3 pattern (bit k: cell k in reading order, the center bit 4): 1 when a
    foreground center stays - removing it changes how many 8-connected groups the pattern
    has, or the pattern has fewer than three cells - else 0."""
    eight = np.ones((3, 3), dtype=bool)
    out = np.zeros(512, dtype=np.uint8)
    for index in range(512):
        pattern = np.array([(index >> k) & 1 for k in range(9)], dtype=bool).reshape(3, 3)
        if not pattern[1, 1]:
            continue
        without = pattern.copy()
        without[1, 1] = False
        splits = ndimage.label(pattern, eight)[1] != ndimage.label(without, eight)[1]
        out[index] = splits or int(pattern.sum()) < 3
    return out


@njit(cache=True, nogil=True)
def _thin(
    result: npt.NDArray[np.uint8], order: npt.NDArray[np.int64], table: npt.NDArray[np.uint8]
) -> None:
    """Visit the cells of ``order`` (flat indices) once each; each becomes what ``table`` says
    of its 3 x 3 neighbourhood as it is then (the outside of the array empty)."""
    H, W = result.shape
    for k in range(order.size):
        here = order[k]
        r, c = here // W, here % W
        index = 16
        if r > 0:
            if c > 0 and result[r - 1, c - 1]:
                index += 1
            if result[r - 1, c]:
                index += 2
            if c < W - 1 and result[r - 1, c + 1]:
                index += 4
        if c > 0 and result[r, c - 1]:
            index += 8
        if c < W - 1 and result[r, c + 1]:
            index += 32
        if r < H - 1:
            if c > 0 and result[r + 1, c - 1]:
                index += 64
            if result[r + 1, c]:
                index += 128
            if c < W - 1 and result[r + 1, c + 1]:
                index += 256
        result[r, c] = table[index]

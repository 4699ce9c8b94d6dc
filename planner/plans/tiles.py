"""The tiled grid memory of the searches: a map's cells kept in 32 x 32 tiles, each allocated
on first touch and found through one small index of tiles, so that a search's memory follows
the cells it reaches, not the map. The goal's resumable search (``search``) and the detour
round dynamic obstacles (``detour``) keep their values in it; a tile's values are one row of
each of the search's pools, a cell's place in that row its offset.

>>> import numpy as np
>>> tile_of = tile_index(40, 70)
>>> tile_of.shape  # 2 x 3 tiles
(6,)
>>> w = tiles_wide(70)
>>> tile_slot(tile_of, w, 33, 65), claim_tile(tile_of, w, 33, 65, 0), tile_slot(tile_of, w, 33, 65)
(-1, 0, 0)
>>> tile_offset(33, 65) == (1 << SHIFT) + 1
True
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = [
    "SHIFT",
    "TILE_CELLS",
    "claim_tile",
    "tile_index",
    "tile_offset",
    "tile_slot",
    "tiles_wide",
]

SHIFT = 5
"""A tile is ``2**SHIFT`` cells a side."""
TILE_CELLS = 1 << (2 * SHIFT)
_MASK = (1 << SHIFT) - 1


def tile_index(H: int, W: int) -> npt.NDArray[np.int32]:
    """The index of an ``H`` x ``W`` map's tiles, none allocated (-1), row by row."""
    if H < 1 or W < 1:
        raise ValueError(f"a map has at least one cell a side; {H} x {W} given.")
    return np.full(((H + _MASK) >> SHIFT) * tiles_wide(W), -1, dtype=np.int32)


@njit(cache=True, nogil=True)
def tiles_wide(W: int) -> int:
    """How many tiles a row of a map ``W`` cells wide spans."""
    return (W + _MASK) >> SHIFT


@njit(cache=True, nogil=True)
def tile_slot(tile_of: np.ndarray, tiles_w: int, r: int, c: int) -> int:
    """The tile holding cell (r, c) (its row in the pools), or -1 when none is allocated."""
    return int(tile_of[(r >> SHIFT) * tiles_w + (c >> SHIFT)])


@njit(cache=True, nogil=True)
def tile_offset(r: int, c: int) -> int:
    """Where cell (r, c) sits in its tile's row."""
    return ((r & _MASK) << SHIFT) | (c & _MASK)


@njit(cache=True, nogil=True)
def claim_tile(tile_of: np.ndarray, tiles_w: int, r: int, c: int, used: int) -> int:
    """The tile holding cell (r, c), allocated as row ``used`` when it had none (the caller
    then fills that row of its pools and counts it used)."""
    t = (r >> SHIFT) * tiles_w + (c >> SHIFT)
    if tile_of[t] < 0:
        tile_of[t] = used
    return int(tile_of[t])

"""The binary min-heap of the searches (the resumable wave's A* and the detour): entries are a
cell and its key ``(f, g)``, lower ``f`` first and, among equal ``f``, higher ``g`` (deeper
cells first: fewer expansions where many paths tie). Stale entries are skipped by the caller."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["heap_pop", "heap_push", "heapify"]


@njit(cache=True, nogil=True)
def _before(keys: np.ndarray, a: int, f: float, g: float) -> bool:
    """Whether heap entry ``a`` comes before an entry (f, g)."""
    return bool(keys[a, 0] < f or (keys[a, 0] == f and keys[a, 1] >= g))


@njit(cache=True, nogil=True)
def _put(keys: np.ndarray, cells: np.ndarray, j: int, f: float, g: float, cell: int) -> None:
    keys[j, 0] = f
    keys[j, 1] = g
    cells[j] = cell


@njit(cache=True, nogil=True)
def heap_push(keys: np.ndarray, cells: np.ndarray, size: int, f: float, g: float, cell: int) -> int:
    """Add ``cell`` with key ``(f, g)`` (``keys`` rows: f, g; room for one more); the new size."""
    j = size
    while j > 0:
        parent = (j - 1) >> 1
        if _before(keys, parent, f, g):
            break
        _put(keys, cells, j, keys[parent, 0], keys[parent, 1], cells[parent])
        j = parent
    _put(keys, cells, j, f, g, cell)
    return size + 1


@njit(cache=True, nogil=True)
def _sift_down(keys: np.ndarray, cells: np.ndarray, j: int, size: int) -> None:
    f = keys[j, 0]
    g = keys[j, 1]
    cell = cells[j]
    while True:
        child = 2 * j + 1
        if child >= size:
            break
        if child + 1 < size and not _before(keys, child, keys[child + 1, 0], keys[child + 1, 1]):
            child += 1
        if not (keys[child, 0] < f or (keys[child, 0] == f and keys[child, 1] > g)):
            break
        _put(keys, cells, j, keys[child, 0], keys[child, 1], cells[child])
        j = child
    _put(keys, cells, j, f, g, cell)


@njit(cache=True, nogil=True)
def heap_pop(keys: np.ndarray, cells: np.ndarray, size: int) -> tuple[int, float, int]:
    """Remove the first entry: (its cell, its g, the new size)."""
    cell = cells[0]
    g = keys[0, 1]
    size -= 1
    if size > 0:
        _put(keys, cells, 0, keys[size, 0], keys[size, 1], cells[size])
        _sift_down(keys, cells, 0, size)
    return cell, g, size


@njit(cache=True, nogil=True)
def heapify(keys: np.ndarray, cells: np.ndarray, size: int) -> None:
    """Order the first ``size`` entries as a heap."""
    for j in range(size // 2 - 1, -1, -1):
        _sift_down(keys, cells, j, size)

"""A step's dynamic obstacles: the cells given, checked (a list of ``[row, col]`` cells inside
the map, else ``InvalidInput`` naming the first that is not), and the cells they block with the
decision's margin."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput

__all__ = ["blocked_cells", "obstacle_cells"]


def obstacle_cells(cells: Any, shape: tuple[int, int]) -> npt.NDArray[np.int64]:
    """``cells`` as an ``(n, 2)`` array of cells inside the map, else ``InvalidInput``."""
    H, W = shape
    if type(cells) is list:  # the usual input, JSON's lists of ints: checked in Python
        flat: list[int] = []
        for cell in cells:
            if type(cell) is not list or len(cell) != 2:
                break
            r, c = cell
            if type(r) is not int or type(c) is not int or not (0 <= r < H and 0 <= c < W):
                break
            flat += cell
        else:
            return np.array(flat, dtype=np.int64).reshape(-1, 2)
    try:
        obstacles = np.asarray(cells, dtype=np.int64)
    except (TypeError, ValueError, OverflowError):
        msg = f"dynamic_obstacles must be a list of [row, col] cells; got {cells!r}"
        raise InvalidInput(msg, field="dynamic_obstacles") from None
    if obstacles.size == 0:
        return np.empty((0, 2), dtype=np.int64)
    if obstacles.ndim != 2 or obstacles.shape[1] != 2:
        msg = f"dynamic_obstacles must be a list of [row, col] cells; got shape {obstacles.shape}"
        raise InvalidInput(msg, field="dynamic_obstacles")
    obstacles = np.ascontiguousarray(obstacles)
    i = _first_outside(obstacles, H, W)  # one pass: a fleet's steps give hundreds of cells
    if i >= 0:
        cell = obstacles[i].tolist()
        msg = f"dynamic_obstacles[{i}] {cell} is outside the {H} x {W} map"
        raise InvalidInput(msg, field="dynamic_obstacles")
    return obstacles


@njit(cache=True, nogil=True)
def _first_outside(cells: Any, H: int, W: int) -> int:
    """The index of the first of the ``(n, 2)`` cells outside ``H`` x ``W``, or -1."""
    for i in range(cells.shape[0]):
        if not (0 <= cells[i, 0] < H and 0 <= cells[i, 1] < W):
            return i
    return -1


def blocked_cells(
    obstacles: npt.NDArray[np.int64], margin: int, shape: tuple[int, int]
) -> npt.NDArray[np.int64]:
    """Flat indices of the cells within Chebyshev ``margin`` of an obstacle, inside the map."""
    H, W = shape
    span = np.arange(-margin, margin + 1)
    dr, dc = np.meshgrid(span, span, indexing="ij")
    rows = (obstacles[:, 0, None] + dr.ravel()).ravel()
    cols = (obstacles[:, 1, None] + dc.ravel()).ravel()
    inside = (rows >= 0) & (rows < H) & (cols >= 0) & (cols < W)
    out: npt.NDArray[np.int64] = rows[inside] * W + cols[inside]
    return out

"""The cells a step's dynamic obstacles block, for the path ahead: a small window's mask of them
(each obstacle's cell and those within the margin), and how far along a route the robot
reaches before one."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput, quote

__all__ = ["reachable", "window"]


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


def window(
    route: npt.NDArray[np.int64],
    shape: tuple[int, int],
    obstacles: npt.NDArray[np.int64],
    *,
    margin: int,
    exempt: int,
) -> tuple[npt.NDArray[np.int64], int, npt.NDArray[np.uint8], int, int]:
    """``route``'s cells ``(m, 2)`` (from flat indices of a map of ``shape``), how many of them
    the robot reaches (as :func:`reachable`), and the mask of the cells the ``obstacles``
    block in a window round the route, with its corner (top, left): what
    :func:`~planner.poses.route_poses.poses_ahead` keeps clear of."""
    H, W = (int(v) for v in shape)
    for name, array, ndim in (("route", route, 1), ("obstacles", obstacles, 2)):
        if not isinstance(array, np.ndarray) or array.dtype != np.int64 or array.ndim != ndim:
            msg = f"{name} must be a {ndim}-D int64 array; got {quote(array)}"
            raise InvalidInput(msg, field=name)
    if len(route) == 0 or route.min() < 0 or route.max() >= H * W:
        msg = f"route must hold flat cells of a {H} x {W} map, one at least; got {quote(route)}"
        raise InvalidInput(msg, field="route")
    if (len(obstacles) and obstacles.shape[1] != 2) or margin < 0 or exempt < 0:
        msg = f"obstacles must be (k, 2) cells, margin and exempt >= 0; got {obstacles.shape!r}"
        raise InvalidInput(msg, field="obstacles")
    flat = np.ascontiguousarray(route)
    cells, n, mask, top, left = _reach(flat, W, H, obstacles, int(margin), int(exempt))
    return cells, int(n), mask, int(top), int(left)


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
    diagonally past one), after the first ``exempt`` moves: those
    :func:`~planner.poses.route_poses.poses_ahead` follows."""
    return window(route, shape, obstacles, margin=margin, exempt=exempt)[1]

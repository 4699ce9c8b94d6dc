"""The replan of docs/algorithm.md, "Dynamic obstacles and stepping": A* from the robot to the goal
round the dynamic obstacles, at
the wide costs (move + clean of the cell entered), over a whole-map wave, a resumable one, or a
grid no wave ran over; its memory grows with the cells it reaches, not the map."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit, types
from numba.typed import Dict

from planner.plans.heap import heap_pop, heap_push
from planner.plans.moves import DC, DR, octile, on_grid
from planner.plans.search import SETTLED, SHIFT, TILE_MASK

__all__ = ["detour_cells"]

_NO_FIELD = np.zeros((0, 0), dtype=np.float64)
_NO_TILES = (
    np.zeros(0, dtype=np.int32),
    np.zeros((0, 1), dtype=np.float64),
    np.zeros((0, 1), dtype=np.uint8),
)


@njit(cache=True, nogil=True)
def _detour(
    codes: np.ndarray,
    open_: int,
    goal: int,
    clean: np.ndarray,
    field: np.ndarray,
    tiles: tuple[np.ndarray, np.ndarray, np.ndarray],
    exhausted: bool,
    start: int,
    diagonal_cost: float,
    obstacles: np.ndarray,
    margin: int,
    limit: int,
) -> tuple[np.ndarray, bool]:
    """A* from ``start`` to ``goal`` over the grid (``codes``, ``open_``: see ``moves``) with
    every cell within Chebyshev ``margin`` of a dynamic obstacle blocked.

    The heuristic is ``kw`` without dynamic obstacles: the whole ``field`` when given (cells it
    marks unreachable are skipped), else a resumable search's ``tiles`` (index, values, states)
    where settled and the octile distance elsewhere (once the search is ``exhausted``, cells it
    did not settle are unreachable). Admissible, so the first time the goal is popped its cost
    is optimal; a cell reached more cheaply later is expanded again. Returns the cells after
    ``start`` up to the goal (flat indices), empty when cut off, and whether it gave up after
    ``limit`` expansions.
    ``start`` itself may be blocked.
    """
    H, W = codes.shape
    tile_of, g_kw, status_kw = tiles
    tiles_w = (W + TILE_MASK) >> SHIFT
    gr = goal // W
    gc = goal - gr * W
    has_field = field.shape[0] > 0
    has_tiles = tile_of.shape[0] > 0
    blocked = Dict.empty(key_type=types.int64, value_type=types.boolean)
    for j in range(obstacles.shape[0]):
        orow = obstacles[j, 0]
        ocol = obstacles[j, 1]
        for r in range(max(orow - margin, 0), min(orow + margin + 1, H)):
            for c in range(max(ocol - margin, 0), min(ocol + margin + 1, W)):
                blocked[r * W + c] = True
    if goal in blocked:
        return np.empty(0, dtype=np.int64), False
    g = Dict.empty(key_type=types.int64, value_type=types.float64)
    parent = Dict.empty(key_type=types.int64, value_type=types.int64)
    keys = np.empty((1024, 2), dtype=np.float64)
    cells = np.empty(1024, dtype=np.int64)
    g[start] = 0.0
    size = heap_push(keys, cells, 0, 0.0, 0.0, start)
    ok = np.empty(8, dtype=np.bool_)
    expansions = 0
    found = False
    while size > 0:
        x, gx, size = heap_pop(keys, cells, size)
        if gx > g[x]:
            continue  # stale: reached more cheaply since
        if x == goal:
            found = True
            break
        expansions += 1
        if expansions > limit:
            break
        xr = x // W
        xc = x - xr * W
        for i in range(8):
            y = (xr + DR[i]) * W + xc + DC[i]
            ok[i] = on_grid(codes, open_, goal, xr + DR[i], xc + DC[i]) and y not in blocked
        for i in range(8):
            if not ok[i] or (i & 1 and not (ok[i - 1] and ok[(i + 1) & 7])):
                continue
            yr = xr + DR[i]
            yc = xc + DC[i]
            y = yr * W + yc
            if has_field:
                h = field[yr, yc]
                if h == np.inf:
                    continue
            else:
                s = tile_of[(yr >> SHIFT) * tiles_w + (yc >> SHIFT)] if has_tiles else -1
                o = ((yr & TILE_MASK) << SHIFT) | (yc & TILE_MASK)
                if s >= 0 and status_kw[s, o] == SETTLED:
                    h = g_kw[s, o]
                elif exhausted:
                    continue  # the goal's search proved it unreachable
                else:
                    h = octile(yr, yc, gr, gc, diagonal_cost, 0.0)
            ng = gx + (diagonal_cost if i & 1 else 1.0) + clean[yr, yc]
            if ng < g.get(y, np.inf):
                g[y] = ng
                parent[y] = x
                if size + 1 > cells.shape[0]:
                    grown_keys = np.empty((2 * cells.shape[0], 2), dtype=np.float64)
                    grown_keys[:size] = keys[:size]
                    keys = grown_keys
                    grown_cells = np.empty(2 * cells.shape[0], dtype=np.int64)
                    grown_cells[:size] = cells[:size]
                    cells = grown_cells
                size = heap_push(keys, cells, size, ng + h, ng, y)
    if not found:
        return np.empty(0, dtype=np.int64), expansions > limit
    count = 0
    x = goal
    while x != start:
        count += 1
        x = parent[x]
    out = np.empty(count, dtype=np.int64)
    x = goal
    for j in range(count - 1, -1, -1):
        out[j] = x
        x = parent[x]
    return out, False


def detour_cells(
    codes: npt.NDArray[np.uint8],
    open_: int,
    goal: int,
    clean: npt.NDArray[np.float32],
    start: int,
    obstacles: npt.NDArray[np.int64],
    *,
    margin: int,
    diagonal_cost: float,
    field: npt.NDArray[np.float64] | None = None,
    tiles: tuple[npt.NDArray[np.int32], npt.NDArray[np.float64], npt.NDArray[np.uint8]]
    | None = None,
    exhausted: bool = False,
    limit: int | None = None,
) -> tuple[npt.NDArray[np.int64], bool]:
    """The detour from flat cell ``start`` to flat ``goal`` (see ``_detour``): (the cells after
    ``start``, flat; whether it gave up after ``limit`` expansions, default the map's cells).

    ``field`` is a whole-map ``kw``; ``tiles`` a resumable search's ``(tile_of, g, status)``
    (with ``exhausted``); neither: the octile heuristic.
    """
    H, W = codes.shape
    if codes.dtype != np.uint8 or clean.shape != codes.shape:
        msg = f"codes must be uint8 and clean of its shape; {codes.dtype} {codes.shape!r} and "
        raise TypeError(msg + f"{clean.shape!r} given.")
    if not (0 <= start < H * W and 0 <= goal < H * W):
        raise ValueError(f"start {start} and goal {goal} must be cells of the {H} x {W} map.")
    if field is not None and field.shape != codes.shape:
        raise TypeError(f"field must have the map's shape; {field.shape!r} given.")
    obstacles = np.ascontiguousarray(obstacles, dtype=np.int64).reshape(-1, 2)
    return _detour(
        codes, open_, goal, clean, _NO_FIELD if field is None else field,
        _NO_TILES if tiles is None else tiles, exhausted, start, float(diagonal_cost), obstacles,
        int(margin), H * W if limit is None else int(limit),
    )  # fmt: skip

"""The replan round dynamic obstacles (docs/algorithm.md): A* from the robot to the goal at the
wide costs, over any wave or none; its memory grows with the cells it reaches, not the map."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.plans.heap import heap_pop, heap_push
from planner.plans.moves import DC, DR, octile, on_grid
from planner.plans.search import settled_value
from planner.plans.tiles import TILE_CELLS, claim_tile, tile_offset, tile_slot, tiles_wide

__all__ = ["detour_cells"]

_NO_FIELD = np.zeros((0, 0), dtype=np.float64)
_NO_TILES = (
    np.zeros(0, dtype=np.int32),
    np.zeros((0, 1), dtype=np.float64),
    np.zeros((0, 1), dtype=np.uint8),
)


@njit(cache=True, nogil=True)
def _exact(
    r: int, c: int, W: int, field: np.ndarray, tiles: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> float:
    """The wave's ``kw`` at (r, c) of a map ``W`` wide where it is known exactly (the whole
    ``field``, else the resumable search's settled ``tiles``), else +inf."""
    if field.shape[0] > 0:
        return float(field[r, c])
    tile_of, g_kw, status_kw = tiles
    if tile_of.shape[0] == 0:
        return np.inf
    return settled_value(tile_of, tiles_wide(W), g_kw, status_kw, r, c)


@njit(cache=True, nogil=True)
def _descends_clear(
    codes: np.ndarray,
    open_: int,
    goal: int,
    clean: np.ndarray,
    field: np.ndarray,
    tiles: tuple[np.ndarray, np.ndarray, np.ndarray],
    diagonal_cost: float,
    own: np.ndarray,
    blocked: np.ndarray,
    seen: np.ndarray,
    top: int,
    left: int,
    x: int,
) -> bool:
    """Whether the wave's descent from flat cell ``x`` (the move of least ``cost + clean +
    kw`` over exactly known ``kw``, each lowering it) enters no blocked cell of the search's
    own tiles (index ``own``, ``blocked`` flags) before it leaves ``seen``, the cells of the
    map in the bounded search's square (its corner at ``top``, ``left``), or reaches the goal,
    or finds no known way down.

    ``seen`` remembers the answer for the cells of the square it walks (-1: not known yet, 0:
    clear, 1: not): descents merge, so each cell is walked down at most once a search."""
    W = codes.shape[1]
    own_w = tiles_wide(W)
    r = x // W
    c = x - r * W
    if seen[r - top, c - left] >= 0:
        return seen[r - top, c - left] == 0
    walked = [(r - top) * seen.shape[1] + c - left]
    here = _exact(r, c, W, field, tiles)
    verdict = 0
    while r * W + c != goal:
        best = np.inf
        br, bc = -1, -1
        for i in range(8):
            yr = r + DR[i]
            yc = c + DC[i]
            if not on_grid(codes, open_, goal, yr, yc):
                continue
            if i & 1:
                a = (i + 7) & 7
                b = (i + 1) & 7
                if not on_grid(codes, open_, goal, r + DR[a], c + DC[a]):
                    continue
                if not on_grid(codes, open_, goal, r + DR[b], c + DC[b]):
                    continue
            kw = _exact(yr, yc, W, field, tiles)
            v = (diagonal_cost if i & 1 else 1.0) + clean[yr, yc] + kw
            if kw < here and v < best:
                best, br, bc = v, yr, yc
        if br < 0:
            break  # no known way down from here: nothing more to check
        if not (0 <= br - top < seen.shape[0] and 0 <= bc - left < seen.shape[1]):
            break  # out of the square: clear so far
        t = tile_slot(own, own_w, br, bc)
        if t >= 0 and blocked[t, tile_offset(br, bc)]:
            verdict = 1
            break
        if seen[br - top, bc - left] >= 0:
            verdict = seen[br - top, bc - left]
            break
        walked.append((br - top) * seen.shape[1] + bc - left)
        r, c, here = br, bc, _exact(br, bc, W, field, tiles)
    flat = seen.ravel()
    for i in walked:
        flat[i] = verdict
    return verdict == 0


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
    within: int,
) -> tuple[np.ndarray, bool]:
    """A* from ``start`` to ``goal`` over the grid (``codes``, ``open_``: see ``moves``) with
    every cell within Chebyshev ``margin`` of a dynamic obstacle blocked.

    With ``within`` >= 0 the search is bounded to the square of Chebyshev radius ``2 *
    within`` round ``start`` (the dynamic obstacles beyond it are not read) and hands over to
    the wave beyond the window of radius ``within``: a cell outside that window whose
    heuristic is the wave's exact cost-to-go, and whose descent meets no blocked cell before
    it leaves the square (:func:`_descends_clear`), ends the search when popped (its ``g`` plus
    that cost is then the least of any way out), and the cells returned end there. A goal
    blocked in the square ends the search with no cells (no way exists now), one beyond it
    does not. No such cell: no cells (the caller may search the whole map).

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
    tiles_w = tiles_wide(W)
    gr = goal // W
    gc = goal - gr * W
    sr = start // W
    sc = start - sr * W
    end = goal
    has_field = field.shape[0] > 0
    has_tiles = tile_of.shape[0] > 0
    # The search's own memory, in tiles allocated on first touch: g, parents, blocked flags.
    own_w = tiles_wide(W)
    own = np.full(tiles_wide(H) * own_w, -1, dtype=np.int32)  # rows of tiles: as wide
    g = np.empty((4, TILE_CELLS), dtype=np.float64)
    parent = np.empty((4, TILE_CELLS), dtype=np.int64)
    blocked = np.empty((4, TILE_CELLS), dtype=np.uint8)
    at_slot = np.empty(9, dtype=np.int64)  # where x's neighbours are in the tiles, x last
    at_offset = np.empty(9, dtype=np.int64)
    used = 0
    outer = 2 * within if within >= 0 else H + W  # the bounded search's square
    # The descents' verdicts over that square's cells of the map (see _descends_clear).
    top, left = max(sr - outer, 0), max(sc - outer, 0)
    seen_shape = (min(sr + outer, H - 1) - top + 1, min(sc + outer, W - 1) - left + 1)
    seen = np.full(seen_shape if within >= 0 else (0, 0), -1, dtype=np.int8)
    # The cells to touch first: each obstacle's square (in the bounded search's), then the
    # goal and the start.
    first = []
    for j in range(obstacles.shape[0]):
        for r in range(max(obstacles[j, 0] - margin, 0), min(obstacles[j, 0] + margin + 1, H)):
            if abs(r - sr) > outer + 1:
                continue
            for c in range(max(obstacles[j, 1] - margin, 0), min(obstacles[j, 1] + margin + 1, W)):
                if abs(c - sc) <= outer + 1:
                    first.append(r * W + c)
    marked = len(first)
    first.append(goal)
    first.append(start)
    ok = np.empty(8, dtype=np.bool_)
    keys = np.empty((1024, 2), dtype=np.float64)
    cells = np.empty(1024, dtype=np.int64)
    size = 0
    expansions = 0
    found = False
    j = 0
    while j < len(first) or size > 0:
        if used + 4 > g.shape[0]:  # room for the tiles of a 3 x 3 square
            g = np.concatenate((g, np.empty_like(g)))
            parent = np.concatenate((parent, np.empty_like(parent)))
            blocked = np.concatenate((blocked, np.empty_like(blocked)))
        if j < len(first):  # touching the first cells, one a turn
            x = first[j]
            gx = 0.0
            count = 1
        else:
            x, gx, size = heap_pop(keys, cells, size)
            count = 9
        xr = x // W
        xc = x - xr * W
        for i in range(count):
            k = 8 if i == count - 1 else i
            yr = xr + DR[k] if k < 8 else xr
            yc = xc + DC[k] if k < 8 else xc
            if k < 8:
                ok[k] = on_grid(codes, open_, goal, yr, yc)
                if not ok[k]:
                    continue
            s = claim_tile(own, own_w, yr, yc, used)
            if s == used:
                used += 1
                g[s, :] = np.inf
                parent[s, :] = -1
                blocked[s, :] = 0
            at_slot[k] = s
            at_offset[k] = tile_offset(yr, yc)
        if j < len(first):
            if j < marked:
                blocked[at_slot[8], at_offset[8]] = 1
            elif x == goal and blocked[at_slot[8], at_offset[8]]:
                if max(abs(gr - sr), abs(gc - sc)) <= outer:  # the goal cut off
                    return np.empty(0, dtype=np.int64), False
            elif x == start:
                g[at_slot[8], at_offset[8]] = 0.0
                size = heap_push(keys, cells, 0, 0.0, 0.0, start)
            j += 1
            continue
        if gx > g[at_slot[8], at_offset[8]]:
            continue  # stale: reached more cheaply since
        if x == goal:
            found = True
            break
        # Out of the window, the wave takes over where its cost-to-go is exact and its descent
        # from there meets no blocked cell for a while (else the search goes on).
        if (
            within >= 0
            and max(abs(xr - sr), abs(xc - sc)) > within
            and _exact(xr, xc, W, field, tiles) < np.inf
            and _descends_clear(
                codes, open_, goal, clean, field, tiles, diagonal_cost, own, blocked, seen, top,
                left, x,
            )
        ):  # fmt: skip
            end, found = x, True
            break
        expansions += 1
        if expansions > limit:
            break
        for i in range(8):
            if ok[i]:
                ok[i] = blocked[at_slot[i], at_offset[i]] == 0
        for i in range(8):
            if not ok[i] or (i & 1 and not (ok[i - 1] and ok[(i + 1) & 7])):
                continue
            yr = xr + DR[i]
            yc = xc + DC[i]
            if max(abs(yr - sr), abs(yc - sc)) > outer:
                continue  # beyond the bounded search's square
            if has_field:
                h = field[yr, yc]
                if h == np.inf:
                    continue
            else:
                h = np.inf
                if has_tiles:
                    h = settled_value(tile_of, tiles_w, g_kw, status_kw, yr, yc)
                if h == np.inf:
                    if exhausted:
                        continue  # the goal's search proved it unreachable
                    h = octile(yr, yc, gr, gc, diagonal_cost, 0.0)
            ng = gx + (diagonal_cost if i & 1 else 1.0) + clean[yr, yc]
            if ng < g[at_slot[i], at_offset[i]]:
                g[at_slot[i], at_offset[i]] = ng
                parent[at_slot[i], at_offset[i]] = x
                if size + 1 > cells.shape[0]:
                    grown_keys = np.empty((2 * cells.shape[0], 2), dtype=np.float64)
                    grown_keys[:size] = keys[:size]
                    keys = grown_keys
                    grown_cells = np.empty(2 * cells.shape[0], dtype=np.int64)
                    grown_cells[:size] = cells[:size]
                    cells = grown_cells
                size = heap_push(keys, cells, size, ng + h, ng, yr * W + yc)
    if not found:
        return np.empty(0, dtype=np.int64), expansions > limit
    path = [end]
    while path[-1] != start:
        r = path[-1] // W
        c = path[-1] - r * W
        path.append(parent[tile_slot(own, own_w, r, c), tile_offset(r, c)])
    out = np.empty(len(path) - 1, dtype=np.int64)
    for j in range(len(path) - 1):
        out[j] = path[len(path) - 2 - j]
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
    within: int | None = None,
) -> tuple[npt.NDArray[np.int64], bool]:
    """The detour from flat cell ``start`` to flat ``goal`` (see ``_detour``): (the cells after
    ``start``, flat; whether it gave up after ``limit`` expansions, default the map's cells).
    With ``within`` (cells), the search stays in the window of that Chebyshev radius round
    ``start`` and the cells end at the first cell beyond it where the wave's cost-to-go is
    exact (the wave's own descent goes on from there), or at the goal.

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
    if within is not None and within < 0:
        raise ValueError(f"within must be a number of cells >= 0; {within!r} given.")
    obstacles = np.ascontiguousarray(obstacles, dtype=np.int64).reshape(-1, 2)
    return _detour(
        codes, open_, goal, clean, _NO_FIELD if field is None else field,
        _NO_TILES if tiles is None else tiles, exhausted, start, float(diagonal_cost), obstacles,
        int(margin), H * W if limit is None else int(limit), -1 if within is None else int(within),
    )  # fmt: skip

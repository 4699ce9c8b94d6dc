"""What a decision reads of a goal wave and the path it follows with no dynamic obstacles: the
walk down whole fields, and, over a resumable wave, the 3 x 3 windows of settled cells and the
walk for as long as they are settled."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.plans.decide import MODE_PAPER, MODE_WIDE, MOVE, Rule, decide_core
from planner.plans.moves import DC, DR, on_grid
from planner.plans.search import GoalSearch, is_settled, settled_value
from planner.plans.tiles import tiles_wide
from planner.plans.whole_wave import WaveView

__all__ = [
    "WALK_ARRIVED",
    "WALK_STUCK",
    "WALK_TOO_LONG",
    "WALK_UNSETTLED",
    "neighbourhood",
    "settled_around",
    "walk_fields",
    "walk_settled",
    "window",
]

#: Both searches' tiles, as the kernels take them: ``k``'s tile index, values and states, then
#: ``kw``'s.
Tiles = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]

WALK_ARRIVED = 0
WALK_UNSETTLED = 1
WALK_STUCK = 2
WALK_TOO_LONG = 3


@njit(cache=True, nogil=True)
def _walk(
    view: WaveView, start: int, goal: int, rule: Rule, max_steps: int, partial: bool
) -> np.ndarray:
    """The path (flat indices, start first) the decision follows with no dynamic obstacles down
    a whole-map ``view``; when the goal is not reached within ``max_steps`` moves, empty, or
    with ``partial`` its first ``max_steps`` moves."""
    H, W = view.passable.shape
    mode = rule.mode
    # Only the paper decision keeps a tabu list; the wide one never revisits a cell.
    visited = np.zeros(H * W if mode == MODE_PAPER else 1, dtype=np.uint8)
    path = np.empty(min(max_steps + 1, 1024), dtype=np.int64)
    contact = np.zeros(8, dtype=np.int64)
    gr = goal // W
    gc = goal - gr * W
    x = start
    path[0] = x
    if mode == MODE_PAPER:
        visited[x] = 1
    n = 1
    while x != goal:
        if n > max_steps:
            return path[:n].copy() if partial else path[:0].copy()
        if n == path.shape[0]:
            grown = np.empty(min(2 * n, max_steps + 1), dtype=np.int64)
            grown[:n] = path
            path = grown
        r = x // W
        c = x - r * W
        tabu = 0
        if mode == MODE_PAPER:
            for i in range(8):
                yr = r + DR[i]
                yc = c + DC[i]
                if 0 <= yr < H and 0 <= yc < W and visited[yr * W + yc]:
                    tabu |= 1 << i
        i, outcome = decide_core(view, r, c, 0, 0, False, contact, tabu, (gr, gc), rule, -1)
        if outcome != MOVE:
            return path[:0].copy()
        x = (r + DR[i]) * W + c + DC[i]
        if mode == MODE_PAPER:
            visited[x] = 1
        path[n] = x
        n += 1
    return path[:n].copy()


def walk_fields(
    view: WaveView, start: int, goal: int, rule: Rule, *, max_steps: int, partial: bool = False
) -> npt.NDArray[np.int64]:
    """The path (flat indices, ``start`` first) the decision of ``rule`` follows down a whole
    wave's fields (its ``view``) with no dynamic obstacles; empty when it does not reach
    ``goal`` within ``max_steps`` moves (with ``partial``: its first ``max_steps`` moves)."""
    n = view.passable.size
    if (
        view.top
        or view.left
        or {view.k.shape, view.kw.shape, view.clean.shape} != {view.passable.shape}
    ):
        raise TypeError("the view must hold whole fields of one shape, from a whole-map wave.")
    if not (0 <= start < n and 0 <= goal < n):
        raise ValueError(f"start {start} and goal {goal} must be cells of the map.")
    out: npt.NDArray[np.int64] = _walk(view, start, goal, rule, max_steps, partial)
    return out


@njit(cache=True, nogil=True)
def _neighbourhood(state: np.ndarray, open_: int, goal: int, r: int, c: int) -> np.ndarray:
    """The cells whose cost-to-go a decision at (r, c) reads: (r, c) itself when on the wave's
    grid, and every neighbour a legal static move reaches (flat indices)."""
    W = state.shape[1]
    out = np.empty(9, dtype=np.int64)
    n = 0
    if on_grid(state, open_, goal, r, c):
        out[n] = r * W + c
        n += 1
    ok = np.empty(8, dtype=np.bool_)
    for i in range(8):
        ok[i] = on_grid(state, open_, goal, r + DR[i], c + DC[i])
    for i in range(8):
        if ok[i] and (not i & 1 or (ok[i - 1] and ok[(i + 1) & 7])):
            out[n] = (r + DR[i]) * W + c + DC[i]
            n += 1
    return out[:n].copy()


@njit(cache=True, nogil=True)
def _settled_around(
    state: np.ndarray,
    open_: int,
    goal: int,
    r: int,
    c: int,
    tiles: Tiles,
) -> bool:
    """Whether every cell a decision at (r, c) reads is settled in both searches."""
    tile_of_k, _, status_k, tile_of_kw, _, status_kw = tiles
    W = state.shape[1]
    tiles_w = tiles_wide(W)
    targets = _neighbourhood(state, open_, goal, r, c)
    for j in range(targets.shape[0]):
        yr = targets[j] // W
        yc = targets[j] - yr * W
        if not is_settled(tile_of_k, tiles_w, status_k, yr, yc):
            return False
        if not is_settled(tile_of_kw, tiles_w, status_kw, yr, yc):
            return False
    return True


@njit(cache=True, nogil=True)
def _window(
    state: np.ndarray,
    clean: np.ndarray,
    open_: int,
    goal: int,
    r: int,
    c: int,
    tiles: Tiles,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The 3 x 3 windows centred on (r, c) of the wave's grid, ``k``, ``kw`` and ``clean``
    (outside the map: not passable, +inf, 0); unsettled cells read +inf."""
    tile_of_k, g_k, status_k, tile_of_kw, g_kw, status_kw = tiles
    H, W = state.shape
    tiles_w = tiles_wide(W)
    passable = np.zeros((3, 3), dtype=np.uint8)
    k = np.full((3, 3), np.inf)
    kw = np.full((3, 3), np.inf)
    cl = np.zeros((3, 3), dtype=np.float32)
    for dr in range(3):
        yr = r + dr - 1
        if yr < 0 or yr >= H:
            continue
        for dc in range(3):
            yc = c + dc - 1
            if yc < 0 or yc >= W:
                continue
            cl[dr, dc] = clean[yr, yc]
            if not on_grid(state, open_, goal, yr, yc):
                continue
            passable[dr, dc] = 1
            k[dr, dc] = settled_value(tile_of_k, tiles_w, g_k, status_k, yr, yc)
            kw[dr, dc] = settled_value(tile_of_kw, tiles_w, g_kw, status_kw, yr, yc)
    return passable, k, kw, cl


@njit(cache=True, nogil=True)
def _walk_settled(
    state: np.ndarray,
    clean: np.ndarray,
    open_: int,
    goal: int,
    tiles: Tiles,
    start: int,
    diagonal_cost: float,
    max_steps: int,
) -> tuple[np.ndarray, int]:
    """The wide decision's walk from ``start`` (as :func:`_walk`) for as long as every
    cell a decision reads is settled in both searches. Returns the cells visited (``start``
    first, flat indices) and why it stopped: WALK_ARRIVED, WALK_UNSETTLED (the last cell's
    neighbourhood needs settling), WALK_STUCK (no move: cannot happen over exact fields) or
    WALK_TOO_LONG."""
    W = state.shape[1]
    gr = goal // W
    gc = goal - gr * W
    rule = (MODE_WIDE, 0.0, 0.0, diagonal_cost)
    contact = np.zeros(8, dtype=np.int64)
    path = np.empty(256, dtype=np.int64)
    path[0] = start
    n = 1
    x = start
    while x != goal:
        if n > max_steps:
            return path[:n].copy(), WALK_TOO_LONG
        r = x // W
        c = x - r * W
        if not _settled_around(state, open_, goal, r, c, tiles):
            return path[:n].copy(), WALK_UNSETTLED
        passable, k, kw, cl = _window(state, clean, open_, goal, r, c, tiles)
        fields = (passable, k, kw, cl)
        goal_here = (gr - r + 1, gc - c + 1)
        i, outcome = decide_core(fields, 1, 1, 0, 0, False, contact, 0, goal_here, rule, -1)
        if outcome != MOVE:
            return path[:n].copy(), WALK_STUCK
        x = (r + DR[i]) * W + c + DC[i]
        if n == path.shape[0]:
            grown = np.empty(2 * n, dtype=np.int64)
            grown[:n] = path
            path = grown
        path[n] = x
        n += 1
    return path[:n].copy(), WALK_ARRIVED


def neighbourhood(
    state: npt.NDArray[np.uint8], open_: int, goal: int, r: int, c: int
) -> npt.NDArray[np.int64]:
    """The cells (flat) a decision at (r, c) reads on the grid (see ``_neighbourhood``)."""
    out: npt.NDArray[np.int64] = _neighbourhood(state, open_, goal, r, c)
    return out


def settled_around(
    state: npt.NDArray[np.uint8],
    open_: int,
    goal: int,
    r: int,
    c: int,
    searches: tuple[GoalSearch, GoalSearch],
) -> bool:
    """Whether every cell a decision at (r, c) reads is settled in both searches (k, kw)."""
    return bool(_settled_around(state, open_, goal, r, c, _tiles(searches)))


def window(
    state: npt.NDArray[np.uint8],
    clean: npt.NDArray[np.float32],
    open_: int,
    goal: int,
    r: int,
    c: int,
    searches: tuple[GoalSearch, GoalSearch],
) -> tuple[
    npt.NDArray[np.uint8], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float32]
]:
    """The 3 x 3 windows centred on (r, c) of the grid, ``k``, ``kw`` and ``clean``."""
    out: tuple[
        npt.NDArray[np.uint8],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float32],
    ] = _window(state, clean, open_, goal, r, c, _tiles(searches))
    return out


def walk_settled(
    state: npt.NDArray[np.uint8],
    clean: npt.NDArray[np.float32],
    open_: int,
    goal: int,
    searches: tuple[GoalSearch, GoalSearch],
    start: int,
    *,
    diagonal_cost: float,
    max_steps: int,
) -> tuple[npt.NDArray[np.int64], int]:
    """The wide walk from ``start`` over what both searches settled (see ``_walk_settled``)."""
    if not 0 <= start < state.size:
        raise ValueError(f"start {start} is not a cell of the {state.shape!r} map.")
    tiles = _tiles(searches)
    path, why = _walk_settled(state, clean, open_, goal, tiles, start, diagonal_cost, max_steps)
    return path, int(why)


def _tiles(searches: tuple[GoalSearch, GoalSearch]) -> Tiles:
    k, kw = searches
    return (k.tile_of, k.g, k.status, kw.tile_of, kw.g, kw.status)

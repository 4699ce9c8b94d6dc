"""Numba kernels of the resumable goal-rooted search (RRA*): private, pure functions.

The search is A* from the goal towards the robot over the cells of an analysed map, with the
octile distance to the robot as its heuristic (every move costs at least its octile length, and
``clean >= 0``, so it is admissible and consistent for ``k`` and for ``kw`` alike: a settled cell's
cost-to-go is exact). It stops as soon as the cells asked for are settled and resumes later, the
open list re-keyed for a new robot cell. Its memory grows with the cells it touches: values live
in 32 x 32 tiles allocated on first touch, found through one small index of tiles.

Mutable scalars travel in ``meta`` (int64): ``[tiles used, heap size, cells settled]``. When the
pools are nearly full a kernel returns ``NEED_SPACE`` before touching anything; the caller grows
them and calls again, so every kernel is resumable at any return.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.typed import Dict

from planner.analysis._kernels import BLOCKED_CELL, DC, DR, FREE, MODE_WIDE, MOVE, _decide_core

SHIFT = 5
TILE = 1 << SHIFT
TILE_MASK = TILE - 1
TILE_CELLS = TILE * TILE

DONE = 0
EXHAUSTED = 1  # the open list is empty: every cell not settled is unreachable
NEED_SPACE = 2
OVER_BUDGET = 3  # ``limit`` cells are settled: the caller may prefer the whole-map wave

WALK_ARRIVED = 0
WALK_UNSETTLED = 1
WALK_STUCK = 2
WALK_TOO_LONG = 3

UNSEEN = 0
OPEN = 1
SETTLED = 2

TILES_USED = 0
HEAP_SIZE = 1
SETTLED_COUNT = 2


@njit(cache=True, nogil=True)
def _passable_at(state: np.ndarray, sealed: bool, goal: int, r: int, c: int) -> bool:
    """Whether (r, c) is on the wave's grid: free (or, unsealed, a tunnel cell), or the goal."""
    H, W = state.shape
    if r < 0 or r >= H or c < 0 or c >= W:
        return False
    if r * W + c == goal:
        return True
    s = state[r, c]
    return bool(s == FREE) if sealed else bool(s != BLOCKED_CELL)


@njit(cache=True, nogil=True)
def _octile(r: int, c: int, tr: int, tc: int, diagonal_cost: float, slack: float) -> float:
    """``max(0, octile((r, c), (tr, tc)) - slack)``: a consistent lower bound of the cost from
    (r, c) to any cell within octile distance ``slack`` of (tr, tc)."""
    dr = abs(r - tr)
    dc = abs(c - tc)
    lo = min(dr, dc)
    hi = max(dr, dc)
    v = (hi - lo) + diagonal_cost * lo - slack
    return v if v > 0.0 else 0.0


# The search's heuristic is the octile bound shrunk by this factor. Settled values are then the
# whole-map wave's to the last bit, not only up to rounding: a cell whose cheapest way runs
# through an open cell (cheaper by a few ulps only, as where paths of equal length add their
# costs in another order) always has a larger key than that cell by at least ``(1 - _SHRINK)``
# times a move, far more than the rounding of the keys (up to costs of ~1e8). So the search
# finds what the bucket queue finds, whichever robots it was aimed at, in whatever order.
_SHRINK = 1.0 - 2.0**-24


@njit(cache=True, nogil=True)
def _heuristic(r: int, c: int, tr: int, tc: int, diagonal_cost: float, slack: float) -> float:
    """The key's heuristic: :func:`_octile`, shrunk (see ``_SHRINK``)."""
    return _octile(r, c, tr, tc, diagonal_cost, slack) * _SHRINK


@njit(cache=True, nogil=True)
def _before(keys: np.ndarray, a: int, f: float, g: float) -> bool:
    """Whether heap entry ``a`` comes before an entry (f, g): the lower f first, then, among
    equal f, the higher g (deeper cells first: fewer expansions where many paths tie)."""
    return bool(keys[a, 0] < f or (keys[a, 0] == f and keys[a, 1] >= g))


@njit(cache=True, nogil=True)
def _heap_push(
    keys: np.ndarray, cells: np.ndarray, size: int, f: float, g: float, cell: int
) -> int:
    """Add ``cell`` with key ``f`` and cost ``g`` to the binary heap (``keys`` rows: f, g)."""
    j = size
    while j > 0:
        parent = (j - 1) >> 1
        if _before(keys, parent, f, g):
            break
        keys[j, 0] = keys[parent, 0]
        keys[j, 1] = keys[parent, 1]
        cells[j] = cells[parent]
        j = parent
    keys[j, 0] = f
    keys[j, 1] = g
    cells[j] = cell
    return size + 1


@njit(cache=True, nogil=True)
def _heap_sift_down(keys: np.ndarray, cells: np.ndarray, j: int, size: int) -> None:
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
        keys[j, 0] = keys[child, 0]
        keys[j, 1] = keys[child, 1]
        cells[j] = cells[child]
        j = child
    keys[j, 0] = f
    keys[j, 1] = g
    cells[j] = cell


@njit(cache=True, nogil=True)
def _slot(tile_of: np.ndarray, tiles_w: int, r: int, c: int) -> int:
    """The tile holding (r, c), or -1 when none is allocated."""
    return int(tile_of[(r >> SHIFT) * tiles_w + (c >> SHIFT)])


@njit(cache=True, nogil=True)
def _start(
    state: np.ndarray,
    root: int,
    tile_of: np.ndarray,
    g: np.ndarray,
    status: np.ndarray,
    keys: np.ndarray,
    cells: np.ndarray,
    meta: np.ndarray,
) -> None:
    """Open the search: the root's tile allocated, the root (the goal, or for a probe the
    robot's cell) queued at cost 0."""
    W = state.shape[1]
    tiles_w = (W + TILE_MASK) >> SHIFT
    r = root // W
    c = root - r * W
    tile_of[(r >> SHIFT) * tiles_w + (c >> SHIFT)] = 0
    g[0, :] = np.inf
    status[0, :] = UNSEEN
    o = ((r & TILE_MASK) << SHIFT) | (c & TILE_MASK)
    g[0, o] = 0.0
    status[0, o] = OPEN
    meta[TILES_USED] = 1
    meta[HEAP_SIZE] = _heap_push(keys, cells, 0, 0.0, 0.0, root)
    meta[SETTLED_COUNT] = 0


@njit(cache=True, nogil=True)
def _resume(
    state: np.ndarray,
    clean: np.ndarray,
    sealed: bool,
    use_clean: bool,
    diagonal_cost: float,
    goal: int,
    tile_of: np.ndarray,
    g: np.ndarray,
    status: np.ndarray,
    keys: np.ndarray,
    cells: np.ndarray,
    meta: np.ndarray,
    targets: np.ndarray,
    tr: int,
    tc: int,
    slack: float,
    limit: int,
) -> int:
    """Expand the best open cell until every cell of ``targets`` (flat indices, each on the
    wave's grid) is settled (DONE), the open list is empty (EXHAUSTED), the pools are nearly
    full (NEED_SPACE) or ``limit`` cells are settled (OVER_BUDGET). The open list is keyed for
    the heuristic ``(tr, tc, slack)`` (any consistent heuristic keeps settled values exact).

    A move X -> Y costs 1 straight or ``diagonal_cost`` diagonally, plus ``clean(Y)`` with
    ``use_clean``; the search runs from the goal, so settling Y relaxes every X with a legal move
    X -> Y at ``g(Y) (+ clean(Y)) + step``.
    """
    W = state.shape[1]
    tiles_w = (W + TILE_MASK) >> SHIFT
    heap_cap = keys.shape[0]
    tile_cap = g.shape[0]
    remaining = 0
    for j in range(targets.shape[0]):
        t = targets[j]
        r = t // W
        c = t - r * W
        s = _slot(tile_of, tiles_w, r, c)
        if s < 0 or status[s, ((r & TILE_MASK) << SHIFT) | (c & TILE_MASK)] != SETTLED:
            remaining += 1
    size = meta[HEAP_SIZE]
    used = meta[TILES_USED]
    settled = meta[SETTLED_COUNT]
    outcome = DONE
    ok = np.empty(8, dtype=np.bool_)
    while remaining > 0:
        if size == 0:
            outcome = EXHAUSTED
            break
        if settled >= limit:
            outcome = OVER_BUDGET
            break
        if size + 8 > heap_cap or (used + 4 > tile_cap and tile_cap < tile_of.shape[0]):
            outcome = NEED_SPACE
            break
        y = cells[0]
        size -= 1
        if size > 0:
            keys[0, 0] = keys[size, 0]
            keys[0, 1] = keys[size, 1]
            cells[0] = cells[size]
            _heap_sift_down(keys, cells, 0, size)
        yr = y // W
        yc = y - yr * W
        ys = _slot(tile_of, tiles_w, yr, yc)
        yo = ((yr & TILE_MASK) << SHIFT) | (yc & TILE_MASK)
        if status[ys, yo] == SETTLED:
            continue  # a stale entry: the cell was queued again at a lower cost
        status[ys, yo] = SETTLED
        settled += 1
        for j in range(targets.shape[0]):
            if targets[j] == y:
                remaining -= 1
        base = g[ys, yo]
        if use_clean:
            base += clean[yr, yc]
        for i in range(0, 8, 2):
            ok[i] = _passable_at(state, sealed, goal, yr + DR[i], yc + DC[i])
        for i in range(1, 8, 2):
            ok[i] = (
                ok[i - 1]
                and ok[(i + 1) & 7]
                and _passable_at(state, sealed, goal, yr + DR[i], yc + DC[i])
            )
        for i in range(8):
            if not ok[i]:
                continue
            xr = yr + DR[i]
            xc = yc + DC[i]
            ti = (xr >> SHIFT) * tiles_w + (xc >> SHIFT)
            xs = tile_of[ti]
            if xs < 0:
                xs = used
                used += 1
                tile_of[ti] = xs
                g[xs, :] = np.inf
                status[xs, :] = UNSEEN
            xo = ((xr & TILE_MASK) << SHIFT) | (xc & TILE_MASK)
            if status[xs, xo] == SETTLED:
                continue
            nd = base + (diagonal_cost if i & 1 else 1.0)
            if nd < g[xs, xo]:
                g[xs, xo] = nd
                status[xs, xo] = OPEN
                h = _heuristic(xr, xc, tr, tc, diagonal_cost, slack)
                size = _heap_push(keys, cells, size, nd + h, nd, xr * W + xc)
    meta[HEAP_SIZE] = size
    meta[TILES_USED] = used
    meta[SETTLED_COUNT] = settled
    return outcome


@njit(cache=True, nogil=True)
def _rekey(
    W: int,
    diagonal_cost: float,
    tile_of: np.ndarray,
    g: np.ndarray,
    status: np.ndarray,
    keys: np.ndarray,
    cells: np.ndarray,
    meta: np.ndarray,
    tr: int,
    tc: int,
    slack: float,
) -> None:
    """Key the open list for a new heuristic target, dropping stale entries, and re-heap it."""
    tiles_w = (W + TILE_MASK) >> SHIFT
    n = 0
    for j in range(meta[HEAP_SIZE]):
        x = cells[j]
        r = x // W
        c = x - r * W
        s = _slot(tile_of, tiles_w, r, c)
        o = ((r & TILE_MASK) << SHIFT) | (c & TILE_MASK)
        if status[s, o] != OPEN:
            continue
        keys[n, 0] = g[s, o] + _heuristic(r, c, tr, tc, diagonal_cost, slack)
        keys[n, 1] = g[s, o]
        cells[n] = x
        n += 1
    for j in range(n // 2 - 1, -1, -1):
        _heap_sift_down(keys, cells, j, n)
    meta[HEAP_SIZE] = n


@njit(cache=True, nogil=True)
def _settled_values(
    W: int, tile_of: np.ndarray, g: np.ndarray, status: np.ndarray, targets: np.ndarray
) -> np.ndarray:
    """The cost-to-go of each cell of ``targets``: exact when settled, else +inf."""
    tiles_w = (W + TILE_MASK) >> SHIFT
    out = np.full(targets.shape[0], np.inf)
    for j in range(targets.shape[0]):
        r = targets[j] // W
        c = targets[j] - r * W
        s = _slot(tile_of, tiles_w, r, c)
        if s >= 0:
            o = ((r & TILE_MASK) << SHIFT) | (c & TILE_MASK)
            if status[s, o] == SETTLED:
                out[j] = g[s, o]
    return out


@njit(cache=True, nogil=True)
def _all_settled(W: int, tile_of: np.ndarray, status: np.ndarray, targets: np.ndarray) -> bool:
    """Whether every cell of ``targets`` (flat indices) is settled."""
    tiles_w = (W + TILE_MASK) >> SHIFT
    for j in range(targets.shape[0]):
        r = targets[j] // W
        c = targets[j] - r * W
        s = _slot(tile_of, tiles_w, r, c)
        if s < 0 or status[s, ((r & TILE_MASK) << SHIFT) | (c & TILE_MASK)] != SETTLED:
            return False
    return True


@njit(cache=True, nogil=True)
def _neighbourhood(state: np.ndarray, sealed: bool, goal: int, r: int, c: int) -> np.ndarray:
    """The cells whose cost-to-go a decision at (r, c) reads: (r, c) itself when on the wave's
    grid, and every neighbour a legal static move reaches (flat indices)."""
    W = state.shape[1]
    out = np.empty(9, dtype=np.int64)
    n = 0
    if _passable_at(state, sealed, goal, r, c):
        out[n] = r * W + c
        n += 1
    ok = np.empty(8, dtype=np.bool_)
    for i in range(8):
        ok[i] = _passable_at(state, sealed, goal, r + DR[i], c + DC[i])
    for i in range(8):
        if ok[i] and (not i & 1 or (ok[i - 1] and ok[(i + 1) & 7])):
            out[n] = (r + DR[i]) * W + c + DC[i]
            n += 1
    return out[:n].copy()


@njit(cache=True, nogil=True)
def _window(
    state: np.ndarray,
    clean: np.ndarray,
    sealed: bool,
    goal: int,
    r: int,
    c: int,
    tile_of_k: np.ndarray,
    g_k: np.ndarray,
    status_k: np.ndarray,
    tile_of_kw: np.ndarray,
    g_kw: np.ndarray,
    status_kw: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The 3 x 3 windows centred on (r, c) of the wave's grid, ``k``, ``kw`` and ``clean``
    (outside the map: not passable, +inf, 0); unsettled cells read +inf."""
    H, W = state.shape
    tiles_w = (W + TILE_MASK) >> SHIFT
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
            if not _passable_at(state, sealed, goal, yr, yc):
                continue
            passable[dr, dc] = 1
            o = ((yr & TILE_MASK) << SHIFT) | (yc & TILE_MASK)
            s = _slot(tile_of_k, tiles_w, yr, yc)
            if s >= 0 and status_k[s, o] == SETTLED:
                k[dr, dc] = g_k[s, o]
            s = _slot(tile_of_kw, tiles_w, yr, yc)
            if s >= 0 and status_kw[s, o] == SETTLED:
                kw[dr, dc] = g_kw[s, o]
    return passable, k, kw, cl


@njit(cache=True, nogil=True)
def _detour(
    state: np.ndarray,
    clean: np.ndarray,
    sealed: bool,
    goal: int,
    tile_of: np.ndarray,
    g_kw: np.ndarray,
    status_kw: np.ndarray,
    exhausted: bool,
    start: int,
    diagonal_cost: float,
    obstacles: np.ndarray,
    margin: int,
    limit: int,
) -> tuple[np.ndarray, bool]:
    """The replan of docs/algorithm.md over a resumable wave: A* from ``start`` to ``goal`` with
    every cell within Chebyshev ``margin`` of a dynamic obstacle blocked, at the wide costs
    (move + clean of the cell entered).

    The heuristic is ``kw`` where the goal's search has settled it and the octile distance to
    the goal elsewhere (cells the search proved unreachable are skipped): admissible but not
    consistent across the two, so a cell is expanded again when it is reached more cheaply, and
    the first time the goal is popped its cost is optimal. Memory: hash maps over the cells
    reached. Returns the cells after ``start`` up to the goal (flat indices), empty when the
    obstacles cut the robot off, and whether it gave up after ``limit`` expansions instead.
    """
    H, W = state.shape
    tiles_w = (W + TILE_MASK) >> SHIFT
    gr = goal // W
    gc = goal - gr * W
    blocked = Dict.empty(key_type=types.int64, value_type=types.boolean)
    for j in range(obstacles.shape[0]):
        orow = obstacles[j, 0]
        ocol = obstacles[j, 1]
        for r in range(max(orow - margin, 0), min(orow + margin + 1, H)):
            for c in range(max(ocol - margin, 0), min(ocol + margin + 1, W)):
                blocked[r * W + c] = True
    g = Dict.empty(key_type=types.int64, value_type=types.float64)
    parent = Dict.empty(key_type=types.int64, value_type=types.int64)
    keys = np.empty((1024, 2), dtype=np.float64)
    cells = np.empty(1024, dtype=np.int64)
    g[start] = 0.0
    size = _heap_push(keys, cells, 0, 0.0, 0.0, start)
    ok = np.empty(8, dtype=np.bool_)
    expansions = 0
    found = False
    while size > 0:
        x = cells[0]
        gx = keys[0, 1]
        size -= 1
        if size > 0:
            keys[0, 0] = keys[size, 0]
            keys[0, 1] = keys[size, 1]
            cells[0] = cells[size]
            _heap_sift_down(keys, cells, 0, size)
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
            ok[i] = _passable_at(state, sealed, goal, xr + DR[i], xc + DC[i]) and y not in blocked
        for i in range(8):
            if not ok[i] or (i & 1 and not (ok[i - 1] and ok[(i + 1) & 7])):
                continue
            yr = xr + DR[i]
            yc = xc + DC[i]
            y = yr * W + yc
            s = _slot(tile_of, tiles_w, yr, yc)
            o = ((yr & TILE_MASK) << SHIFT) | (yc & TILE_MASK)
            if s >= 0 and status_kw[s, o] == SETTLED:
                h = g_kw[s, o]
            elif exhausted:
                continue  # the goal's search proved it unreachable
            else:
                h = _octile(yr, yc, gr, gc, diagonal_cost, 0.0)
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
                size = _heap_push(keys, cells, size, ng + h, ng, y)
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


@njit(cache=True, nogil=True)
def _walk_settled(
    state: np.ndarray,
    clean: np.ndarray,
    sealed: bool,
    goal: int,
    tile_of_k: np.ndarray,
    g_k: np.ndarray,
    status_k: np.ndarray,
    tile_of_kw: np.ndarray,
    g_kw: np.ndarray,
    status_kw: np.ndarray,
    start: int,
    diagonal_cost: float,
    max_steps: int,
) -> tuple[np.ndarray, int]:
    """The wide decision's walk from ``start`` (as ``_kernels._walk``) for as long as every
    cell a decision reads is settled in both searches. Returns the cells visited (``start``
    first, flat indices) and why it stopped: WALK_ARRIVED, WALK_UNSETTLED (the last cell's
    neighbourhood needs settling), WALK_STUCK (no move: cannot happen over exact fields) or
    WALK_TOO_LONG."""
    W = state.shape[1]
    gr = goal // W
    gc = goal - gr * W
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
        if not _settled_around(
            state, sealed, goal, r, c, tile_of_k, status_k, tile_of_kw, status_kw
        ):
            return path[:n].copy(), WALK_UNSETTLED
        passable, k, kw, cl = _window(
            state, clean, sealed, goal, r, c, tile_of_k, g_k, status_k, tile_of_kw, g_kw,
            status_kw,
        )  # fmt: skip
        i, outcome = _decide_core(
            passable, k, kw, cl, 1, 1, 0, 0, False, contact, 0, gr - r + 1, gc - c + 1,
            MODE_WIDE, 0.0, 0.0, diagonal_cost, -1,
        )  # fmt: skip
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


@njit(cache=True, nogil=True)
def _settled_around(
    state: np.ndarray,
    sealed: bool,
    goal: int,
    r: int,
    c: int,
    tile_of_k: np.ndarray,
    status_k: np.ndarray,
    tile_of_kw: np.ndarray,
    status_kw: np.ndarray,
) -> bool:
    """Whether every cell a decision at (r, c) reads is settled in both searches."""
    W = state.shape[1]
    tiles_w = (W + TILE_MASK) >> SHIFT
    targets = _neighbourhood(state, sealed, goal, r, c)
    for j in range(targets.shape[0]):
        yr = targets[j] // W
        yc = targets[j] - yr * W
        o = ((yr & TILE_MASK) << SHIFT) | (yc & TILE_MASK)
        s = _slot(tile_of_k, tiles_w, yr, yc)
        if s < 0 or status_k[s, o] != SETTLED:
            return False
        s = _slot(tile_of_kw, tiles_w, yr, yc)
        if s < 0 or status_kw[s, o] != SETTLED:
            return False
    return True

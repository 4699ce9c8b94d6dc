"""The goal's resumable search (RRA*): A* from the goal towards the robot in tiled memory,
stopped once the cells asked for are settled and resumed later, so memory follows the region."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.analysis.analyse import Analysis
from planner.plans.heap import heap_pop, heap_push, heapify
from planner.plans.moves import DC, DR, octile, on_grid
from planner.plans.tiles import (
    TILE_CELLS,
    claim_tile,
    tile_index,
    tile_offset,
    tile_slot,
    tiles_wide,
)

__all__ = ["GoalSearch", "is_settled", "settled_value"]

DONE = 0
EXHAUSTED = 1  # the open list is empty: every cell not settled is unreachable
NEED_SPACE = 2
OVER_BUDGET = 3  # ``limit`` cells are settled: the caller may prefer the whole-map wave

UNSEEN = 0
OPEN = 1
SETTLED = 2

#: A search's memory, as the kernels take it: the tile index, the tiles' values and states, the
#: open list's keys and cells, ``meta``.
Memory = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]

TILES_USED = 0
HEAP_SIZE = 1
SETTLED_COUNT = 2

# The search's heuristic is the octile bound shrunk by this factor. Settled values are then the
# whole-map wave's to the last bit, not only up to rounding: a cell whose cheapest way runs
# through an open cell (cheaper by a few ulps only, as where paths of equal length add their
# costs in another order) always has a larger key than that cell by at least ``(1 - _SHRINK)``
# times a move, far more than the rounding of the keys (up to costs of ~1e8). So the search
# finds what the bucket queue finds, whichever robots it was aimed at, in whatever order.
_SHRINK = 1.0 - 2.0**-24

# The open list is re-keyed for a new robot cell only when the robot has moved this far (octile)
# from the cell it was keyed for: settled values are exact under any consistent heuristic, so an
# older aim costs only some extra expansions, and re-keying costs a pass over the open list.
_REAIM = 8.0


@njit(cache=True, nogil=True)
def _heuristic(r: int, c: int, tr: int, tc: int, diagonal_cost: float, slack: float) -> float:
    """The key's heuristic: :func:`~planner.plans.moves.octile`, shrunk (see ``_SHRINK``)."""
    return octile(r, c, tr, tc, diagonal_cost, slack) * _SHRINK


@njit(cache=True, nogil=True)
def is_settled(tile_of: np.ndarray, tiles_w: int, status: np.ndarray, r: int, c: int) -> bool:
    """Whether a search (its tile index and states) has settled cell (r, c)."""
    s = tile_slot(tile_of, tiles_w, r, c)
    return s >= 0 and status[s, tile_offset(r, c)] == SETTLED


@njit(cache=True, nogil=True)
def settled_value(
    tile_of: np.ndarray, tiles_w: int, g: np.ndarray, status: np.ndarray, r: int, c: int
) -> float:
    """A search's cost-to-go at cell (r, c): exact where settled, else +inf."""
    s = tile_slot(tile_of, tiles_w, r, c)
    if s >= 0 and status[s, tile_offset(r, c)] == SETTLED:
        return float(g[s, tile_offset(r, c)])
    return np.inf


@njit(cache=True, nogil=True)
def _start(
    state: np.ndarray,
    root: int,
    memory: Memory,
) -> None:
    """Open the search: the root's tile allocated, the root (the goal, or for a probe the
    robot's cell) queued at cost 0."""
    tile_of, g, status, keys, cells, meta = memory
    W = state.shape[1]
    tiles_w = tiles_wide(W)
    r = root // W
    c = root - r * W
    claim_tile(tile_of, tiles_w, r, c, 0)
    g[0, :] = np.inf
    status[0, :] = UNSEEN
    o = tile_offset(r, c)
    g[0, o] = 0.0
    status[0, o] = OPEN
    meta[TILES_USED] = 1
    meta[HEAP_SIZE] = heap_push(keys, cells, 0, 0.0, 0.0, root)
    meta[SETTLED_COUNT] = 0


@njit(cache=True, nogil=True)
def _resume(
    state: np.ndarray,
    clean: np.ndarray,
    open_: int,
    use_clean: bool,
    diagonal_cost: float,
    goal: int,
    tile_of: np.ndarray,  # the memory's arrays one by one here: the hot loop runs faster so
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
    tiles_w = tiles_wide(W)
    heap_cap = keys.shape[0]
    tile_cap = g.shape[0]
    remaining = 0
    for j in range(targets.shape[0]):
        r = targets[j] // W
        if not is_settled(tile_of, tiles_w, status, r, targets[j] - r * W):
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
        y, _, size = heap_pop(keys, cells, size)
        yr = y // W
        yc = y - yr * W
        ys = tile_slot(tile_of, tiles_w, yr, yc)
        yo = tile_offset(yr, yc)
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
            ok[i] = on_grid(state, open_, goal, yr + DR[i], yc + DC[i])
        for i in range(1, 8, 2):
            ok[i] = (
                ok[i - 1]
                and ok[(i + 1) & 7]
                and on_grid(state, open_, goal, yr + DR[i], yc + DC[i])
            )
        for i in range(8):
            if not ok[i]:
                continue
            xr = yr + DR[i]
            xc = yc + DC[i]
            xs = claim_tile(tile_of, tiles_w, xr, xc, used)
            if xs == used:
                used += 1
                g[xs, :] = np.inf
                status[xs, :] = UNSEEN
            xo = tile_offset(xr, xc)
            if status[xs, xo] == SETTLED:
                continue
            nd = base + (diagonal_cost if i & 1 else 1.0)
            if nd < g[xs, xo]:
                g[xs, xo] = nd
                status[xs, xo] = OPEN
                h = _heuristic(xr, xc, tr, tc, diagonal_cost, slack)
                size = heap_push(keys, cells, size, nd + h, nd, xr * W + xc)
    meta[HEAP_SIZE] = size
    meta[TILES_USED] = used
    meta[SETTLED_COUNT] = settled
    return outcome


@njit(cache=True, nogil=True)
def _rekey(
    W: int,
    diagonal_cost: float,
    memory: Memory,
    tr: int,
    tc: int,
    slack: float,
) -> None:
    """Key the open list for a new heuristic target, dropping stale entries, and re-heap it."""
    tile_of, g, status, keys, cells, meta = memory
    tiles_w = tiles_wide(W)
    n = 0
    for j in range(meta[HEAP_SIZE]):
        x = cells[j]
        r = x // W
        c = x - r * W
        s = tile_slot(tile_of, tiles_w, r, c)
        o = tile_offset(r, c)
        if status[s, o] != OPEN:
            continue
        keys[n, 0] = g[s, o] + _heuristic(r, c, tr, tc, diagonal_cost, slack)
        keys[n, 1] = g[s, o]
        cells[n] = x
        n += 1
    heapify(keys, cells, n)
    meta[HEAP_SIZE] = n


@njit(cache=True, nogil=True)
def _settled_values(
    W: int, tile_of: np.ndarray, g: np.ndarray, status: np.ndarray, targets: np.ndarray
) -> np.ndarray:
    """The cost-to-go of each cell of ``targets``: exact when settled, else +inf."""
    tiles_w = tiles_wide(W)
    out = np.full(targets.shape[0], np.inf)
    for j in range(targets.shape[0]):
        r = targets[j] // W
        out[j] = settled_value(tile_of, tiles_w, g, status, r, targets[j] - r * W)
    return out


@njit(cache=True, nogil=True)
def _all_settled(W: int, tile_of: np.ndarray, status: np.ndarray, targets: np.ndarray) -> bool:
    """Whether every cell of ``targets`` (flat indices) is settled."""
    tiles_w = tiles_wide(W)
    for j in range(targets.shape[0]):
        r = targets[j] // W
        if not is_settled(tile_of, tiles_w, status, r, targets[j] - r * W):
            return False
    return True


class GoalSearch:
    """One field's search (``k`` or, with ``use_clean``, ``kw``) and its tiled memory.

    The heuristic is the octile distance to the robot (every move costs at least its octile
    length and ``clean >= 0``: consistent for ``k`` and ``kw`` alike, so a settled cell's
    cost-to-go is exact). Values live in the tiled grid memory (``tiles``): tiles allocated on
    first touch, found through one small index of tiles; mutable scalars travel in ``meta``
    (int64): ``[tiles used, heap size, cells settled]``. When the pools are nearly full a
    kernel returns ``NEED_SPACE`` before touching anything; the search grows them and calls
    again, so every kernel is resumable at any return.
    """

    def __init__(
        self,
        analysis: Analysis,
        goal: int,
        *,
        open_: int,
        use_clean: bool,
        diagonal_cost: float,
        root: int | None = None,
    ) -> None:
        """A search over the cells on the grid (``open_``: see ``moves``) and ``goal`` (always
        on it), from ``root`` (default: the goal)."""
        H, W = analysis.shape
        self.state = analysis.state
        self.clean = analysis.clean
        self.width = W
        self.goal = goal
        self.open = open_
        self.use_clean = use_clean
        self.diagonal_cost = diagonal_cost
        self.tile_of = tile_index(H, W)
        cap = min(4, self.tile_of.shape[0])
        self.g = np.empty((cap, TILE_CELLS), dtype=np.float64)
        self.status = np.empty((cap, TILE_CELLS), dtype=np.uint8)
        self.keys = np.empty((1024, 2), dtype=np.float64)  # rows: f, g
        self.cells = np.empty(1024, dtype=np.int64)
        self.meta = np.zeros(3, dtype=np.int64)
        self.exhausted = False
        self.aim = divmod(goal, W)
        self.slack = 0.0
        _start(self.state, goal if root is None else root, self._memory)

    @property
    def _memory(self) -> Memory:
        return (self.tile_of, self.g, self.status, self.keys, self.cells, self.meta)

    @property
    def nbytes(self) -> int:
        return sum(int(a.nbytes) for a in self._memory)

    def seen(self, cell: int) -> bool:
        """Whether the search has reached ``cell`` (a flat index): queued or settled."""
        r, c = divmod(cell, self.width)
        tiles_w = tiles_wide(self.width)
        slot = tile_slot(self.tile_of, tiles_w, r, c)
        return slot >= 0 and int(self.status[slot, tile_offset(r, c)]) != UNSEEN

    def done(self, targets: npt.NDArray[np.int64]) -> bool:
        """Whether :meth:`settle` would have nothing to do for ``targets``."""
        return self.exhausted or _all_settled(self.width, self.tile_of, self.status, targets)

    def values(self, targets: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        out: npt.NDArray[np.float64] = _settled_values(
            self.width, self.tile_of, self.g, self.status, targets
        )
        return out

    def settle(
        self, targets: npt.NDArray[np.int64], aim: tuple[int, int], slack: float, limit: int
    ) -> bool:
        """Resume until every cell of ``targets`` (on the grid, within ``slack`` of ``aim``) is
        settled or the open list is empty; False, the search left where it was, when that would
        settle more than ``limit`` cells in all."""
        if self.exhausted or _all_settled(self.width, self.tile_of, self.status, targets):
            return True
        d = self.aim[0] - aim[0], self.aim[1] - aim[1]
        if max(abs(d[0]), abs(d[1])) > _REAIM:
            self.aim, self.slack = aim, slack
            _rekey(self.width, self.diagonal_cost, self._memory, aim[0], aim[1], slack)
        tr, tc = self.aim
        while True:
            outcome = _resume(
                self.state, self.clean, self.open, self.use_clean, self.diagonal_cost,
                self.goal, *self._memory, targets, tr, tc, self.slack, limit,
            )  # fmt: skip
            if outcome == NEED_SPACE:
                self._grow()
                continue
            self.exhausted = outcome == EXHAUSTED
            return outcome != OVER_BUDGET

    def settle_paced(
        self,
        targets: npt.NDArray[np.int64],
        aim: tuple[int, int],
        slack: float,
        probe: int,
        limit: int,
    ) -> bool:
        """:meth:`settle` up to ``probe`` cells, then on to ``limit`` only if at the pace of its
        :meth:`headway` the search would be done by then; False past either (the caller may
        prefer the whole-map wave)."""
        if self.settle(targets, aim, slack, min(probe, limit)):
            return True
        if probe >= limit or int(self.meta[SETTLED_COUNT]) > self.headway() * limit:
            return False
        return self.settle(targets, aim, slack, limit)

    def headway(self) -> float:
        """The share of the way from the goal to the cell aimed at that the search's front has
        covered (0 to 1): one less the least heuristic on its open list over the goal's."""
        tr, tc = self.aim
        gr, gc = divmod(self.goal, self.width)
        whole = _heuristic(gr, gc, tr, tc, self.diagonal_cost, self.slack)
        size = int(self.meta[HEAP_SIZE])
        if whole <= 0.0 or size == 0:
            return 1.0
        left = float(np.min(self.keys[:size, 0] - self.keys[:size, 1]))
        return max(0.0, 1.0 - left / whole)

    def release(self) -> None:
        """Drop the memory: the whole-map wave answers from now on."""
        self.tile_of = np.empty(0, dtype=np.int32)
        self.g = np.empty((0, TILE_CELLS), dtype=np.float64)
        self.status = np.empty((0, TILE_CELLS), dtype=np.uint8)
        self.keys = np.empty((0, 2), dtype=np.float64)
        self.cells = np.empty(0, dtype=np.int64)

    def _grow(self) -> None:
        if self.meta[HEAP_SIZE] + 8 > self.keys.shape[0]:
            n = 2 * self.keys.shape[0]
            self.keys = np.concatenate([self.keys, np.empty_like(self.keys)])
            self.cells = np.concatenate([self.cells, np.empty_like(self.cells)])
            assert self.keys.shape[0] == n
        used, cap = int(self.meta[TILES_USED]), self.g.shape[0]
        if used + 4 > cap and cap < self.tile_of.shape[0]:
            grown = min(2 * cap, self.tile_of.shape[0])
            g = np.empty((grown, TILE_CELLS), dtype=np.float64)
            status = np.empty((grown, TILE_CELLS), dtype=np.uint8)
            g[:used] = self.g[:used]
            status[:used] = self.status[:used]
            self.g, self.status = g, status

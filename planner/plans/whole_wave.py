"""The goal wave over the whole map (docs/algorithm.md, "Analysis"): the cost-to-go fields ``k``
and ``kw`` of
every cell, by a Dijkstra wave from the goal, and what a decision reads of them."""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.analysis.analyse import Analysis
from planner.analysis.cells import BLOCKED_CELL, slide_rows
from planner.errors import InvalidInput, quote
from planner.maps.grids import as_cell
from planner.params import PARAMETER_RANGES, SQRT2
from planner.plans.detour import detour_cells
from planner.plans.moves import DC, DR, OPEN_PASSABLE

__all__ = ["Cells", "Clean", "Wave", "WaveView", "goal_wave", "wave_goal"]

Cells = npt.NDArray[np.int64]
"""Cells as flat indices ``r * W + c``, or as ``(n, 2)`` rows ``[r, c]``."""
Clean = npt.NDArray[np.float32]

# From this many cells on, a goal wave computes ``k`` and ``kw`` in two threads at once.
_THREADED_CELLS = 1 << 16


@njit(cache=True, nogil=True)
def _move_masks(passable: np.ndarray) -> np.ndarray:
    """Bit i of each passable cell set when move i from it is legal (inside the map, target
    passable, both orthogonal cells of a diagonal passable); 0 for cells that are not passable.
    Row by row over zero-padded copies of three rows, every inner loop branch-free along a row;
    the wave then reads one byte per cell instead of up to three cells and four bounds a move."""
    H, W = passable.shape
    out = np.zeros((H, W), dtype=np.uint8)
    pad = np.zeros((3, W + 2), dtype=np.uint8)  # rows r - 1, r, r + 1; columns shifted by one
    for r in range(H):
        up, mid, down = slide_rows(pad, passable, r, 0)
        for c in range(W):
            n = up[c + 1]
            s = down[c + 1]
            w = mid[c]
            e = mid[c + 2]
            ne = n & e & up[c + 2]
            se = s & e & down[c + 2]
            sw = s & w & down[c]
            nw = n & w & up[c]
            bits = n | ne << 1 | e << 2 | se << 3 | s << 4 | sw << 5 | w << 6 | nw << 7
            out[r, c] = bits * mid[c + 1]
    return out


@njit(cache=True, nogil=True)
def _wave(
    masks: np.ndarray, goal: int, diagonal_cost: float, clean: np.ndarray, use_clean: bool
) -> np.ndarray:
    """Cost-to-go to ``goal`` of every cell: ``k`` (plain) or, with ``use_clean``, ``kw``.

    A move X -> Y costs 1 straight or ``diagonal_cost`` diagonally, plus ``clean(Y)`` for kw;
    ``masks`` (from :func:`_move_masks`) says which moves are legal. Unreachable: +inf.

    Every move costs at least 1, so cells whose cost-to-go has the same integer part cannot
    improve one another: a bucket queue of width 1 may settle each bucket's cells in any order
    and still gives exactly Dijkstra's result, with O(1) pushes and pops. The buckets are a ring
    of a power of two (larger than the largest move cost) indexed by ``floor(cost)``, each a
    singly linked list of entries drawn from a pool that grows with the wave's front, not with
    the map (:func:`_front`): the wave holds one float64 a cell, the costs it returns.
    """
    H, W = masks.shape
    n = H * W
    moves = masks.ravel()
    pen = clean.ravel()
    largest = max(diagonal_cost, 1.0)
    if use_clean:
        top = 0.0
        for i in range(n):
            if moves[i] and pen[i] > top:
                top = pen[i]
        largest += top
    ring = 1
    while ring < int(largest) + 2:
        ring *= 2
    offset = np.empty(8, dtype=np.int64)
    step = np.empty(8, dtype=np.float64)
    for i in range(8):
        offset[i] = DR[i] * W + DC[i]
        step[i] = diagonal_cost if i & 1 else 1.0
    head = np.full(ring, -1, dtype=np.int64)
    cell = np.empty(1024, dtype=np.int64)
    nxt = np.empty(1024, dtype=np.int64)
    dist = np.full(n, np.inf)
    dist[goal] = 0.0
    cell[0] = goal
    nxt[0] = -1
    head[0] = 0
    state = np.array([0, -1, 1, 1], dtype=np.int64)  # bucket, free, used, queued
    while not _front(moves, pen, use_clean, offset, step, dist, head, cell, nxt, state):
        size = cell.size  # the front outgrew the pool: double it and go on
        cell = np.concatenate((cell, np.empty(size, dtype=np.int64)))
        nxt = np.concatenate((nxt, np.empty(size, dtype=np.int64)))
    return dist.reshape(H, W)


@njit(cache=True, nogil=True)
def _front(
    moves: np.ndarray,
    pen: np.ndarray,
    use_clean: bool,
    offset: np.ndarray,
    step: np.ndarray,
    dist: np.ndarray,
    head: np.ndarray,
    cell: np.ndarray,
    nxt: np.ndarray,
    state: np.ndarray,
) -> bool:
    """:func:`_wave`'s bucket queue, run until it is empty (True) or its pool of entries
    (``cell`` and ``nxt``) may lack room for a cell's eight moves (False: the caller grows it
    and calls again; ``state`` holds the bucket, the free list, the entries used and queued).

    A cell whose cost drops to a lower bucket is pushed again and the entry it leaves behind is
    skipped when its bucket comes (lazy deletion); one whose cost drops within its bucket stays
    where it is. Kept apart from :func:`_wave` so that the pool's arrays are never rebound
    inside the loop (numba then reloads them at every access: twice the time)."""
    wrap = head.size - 1
    bucket, free, used, queued = state[0], state[1], state[2], state[3]
    done = True
    while queued > 0:
        b = bucket & wrap
        while head[b] != -1:  # moves cost at least 1: nothing joins the bucket being emptied
            if cell.size - queued < 8:
                done = False
                break
            e = head[b]
            head[b] = nxt[e]
            y = cell[e]
            nxt[e] = free
            free = e
            queued -= 1
            if int(dist[y]) != bucket:  # left behind: the cell went to a lower bucket
                continue
            base = dist[y] + pen[y] if use_clean else dist[y]
            m = moves[y]
            for i in range(8):
                if not (m >> i) & 1:
                    continue
                x = y + offset[i]
                nd = base + step[i]
                # A settled cell's cost is below every cost offered to it later: no state needed.
                if nd < dist[x]:
                    old = dist[x]
                    dist[x] = nd
                    t = int(nd)
                    if old < np.inf and int(old) == t:
                        continue  # queued in that bucket already
                    if free != -1:
                        f = free
                        free = nxt[f]
                    else:
                        f = used
                        used += 1
                    cell[f] = x
                    nxt[f] = head[t & wrap]
                    head[t & wrap] = f
                    queued += 1
        if not done:
            break
        bucket += 1
    state[0], state[1], state[2], state[3] = bucket, free, used, queued
    return done


class WaveView(NamedTuple):
    """The part of a wave a decision at a cell reads, as arrays that the decision kernels take:
    the wave's grid, ``k``, ``kw`` and ``clean`` over a window whose top-left cell is
    (``top``, ``left``) of the map (the whole map for a whole-map wave; the 3 x 3 cells around
    the robot, settled, for a resumable one)."""

    passable: npt.NDArray[np.uint8]
    k: npt.NDArray[np.float64]
    kw: npt.NDArray[np.float64]
    clean: npt.NDArray[np.float32]
    top: int
    left: int


class Wave:
    """The goal wave: cost-to-go fields over the whole map.

    ``k`` is the plain cost-to-go (the paper's pheromone trail, summed as "total arc cost");
    ``kw`` the wide one, where entering a cell Y also pays ``clean(Y)``. Unreachable: +inf.
    ``passable`` is the grid the wave ran over (sealed or, with ``narrow``, unsealed; the goal
    is always passable).
    """

    def __init__(
        self,
        goal: tuple[int, int],
        k: npt.NDArray[np.float64],
        kw: npt.NDArray[np.float64],
        passable: npt.NDArray[np.uint8],
        *,
        narrow: bool,
        diagonal_cost: float,
        elapsed_ms: float,
    ) -> None:
        self.goal = goal
        self._k = k
        self._kw = kw
        self._passable = passable
        self.narrow = narrow
        self.diagonal_cost = diagonal_cost
        self.elapsed_ms = elapsed_ms
        self._view: WaveView | None = None
        for arr in (k, kw, passable):
            arr.flags.writeable = False

    @property
    def k(self) -> npt.NDArray[np.float64]:
        """The plain cost-to-go of every cell."""
        return self._k

    @property
    def kw(self) -> npt.NDArray[np.float64]:
        """The wide cost-to-go of every cell."""
        return self._kw

    @property
    def passable(self) -> npt.NDArray[np.uint8]:
        """1 on the cells of the grid the wave ran over."""
        return self._passable

    def view(self, r: int, c: int, clean: npt.NDArray[np.float32]) -> WaveView:
        """What a decision at (r, c) reads (see :class:`WaveView`): here, the whole fields
        (one view, kept: a stepping robot asks for it several times a step)."""
        view = self._view
        if view is None or view.clean is not clean:
            view = self._view = WaveView(self.passable, self.k, self.kw, clean, 0, 0)
        return view

    def detour(
        self,
        start: int,
        obstacles: Cells,
        clean: Clean,
        margin: int = 0,
        within: int | None = None,
    ) -> Cells:
        """The replan of docs/algorithm.md, "Dynamic obstacles and stepping" from ``start`` (a flat
        index) over the wave's grid with
        every cell within Chebyshev ``margin`` of a dynamic obstacle blocked: the cells after
        ``start`` up to the goal, empty when cut off. With ``within`` (cells), a search of the
        window round ``start`` whose cells end where the wave takes over, beyond it."""
        W = self.shape[1]
        out, _ = detour_cells(
            self.passable, OPEN_PASSABLE, self.goal[0] * W + self.goal[1], clean, start,
            obstacles, margin=margin, diagonal_cost=self.diagonal_cost, field=self.kw,
            within=within,
        )  # fmt: skip
        return out

    def on_grid(self, cells: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
        """Whether each cell (flat indices) is on the grid the wave ran over."""
        out: npt.NDArray[np.bool_] = self.passable.ravel()[cells] == 1
        return out

    def k_at(self, r: int, c: int) -> float:
        """``k`` at (r, c)."""
        return float(self.k[r, c])

    def k_along(self, path: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """``k`` of each cell of ``path`` (``(n, 2)`` cells)."""
        out: npt.NDArray[np.float64] = self.k[path[:, 0], path[:, 1]]
        return out

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self._passable.shape[0]), int(self._passable.shape[1]))

    def tau(
        self, rho: float = 0.98, *, tau_min: float = 0.01, tau_max: float = 1.0
    ) -> npt.NDArray[np.float64]:
        """The MMAS pheromone of every cell, ``clamp(tau_max * rho ** k, tau_min, tau_max)``."""
        with np.errstate(over="ignore", under="ignore"):
            out: npt.NDArray[np.float64] = np.clip(tau_max * rho**self.k, tau_min, tau_max)
        return out

    @property
    def nbytes(self) -> int:
        shared = self._kw is self._k
        return int(self.k.nbytes + (0 if shared else self.kw.nbytes) + self.passable.nbytes)


def wave_goal(analysis: Analysis, goal: Any, diagonal_cost: float) -> tuple[int, int]:
    """A wave's goal as a cell (``goal`` a ``[row, col]`` cell or a point ``{"x", "y"}`` in
    meters), checked with the wave's ``diagonal_cost``: what every goal wave validates."""
    if isinstance(goal, Mapping):  # a point in meters: the cell holding it
        r, c = analysis.frame.cell_of(goal, name="goal")
    else:
        r, c = as_cell(goal, analysis.shape, name="goal")
    if analysis.state[r, c] == BLOCKED_CELL:
        raise InvalidInput(f"goal [{r}, {c}] is on an obstacle", field="goal")
    low, high = PARAMETER_RANGES["diagonal_cost"]
    if not low <= diagonal_cost <= high:
        msg = f"diagonal_cost must be in [{low}, {high}]; got {quote(diagonal_cost)}"
        raise InvalidInput(msg, field="params.diagonal_cost")
    return r, c


def goal_wave(
    analysis: Analysis, goal: Any, *, diagonal_cost: float = SQRT2, narrow: bool = False
) -> Wave:
    """Run the goal wave over ``analysis``'s sealed grid (or, with ``narrow``, the unsealed one).
    ``goal`` is a ``[row, col]`` cell or a point ``{"x", "y"}`` in meters.

    >>> from planner import analyse
    >>> w = goal_wave(analyse([[0, 0], [0, 0]], seal_tunnels=False, clean_weight=0), [0, 0])
    >>> w.k.round(3).tolist()
    [[0.0, 1.0], [1.0, 1.414]]
    """
    r, c = wave_goal(analysis, goal, diagonal_cost)
    t0 = time.perf_counter()
    passable = analysis.passable(narrow=narrow)
    passable[r, c] = 1
    flat_goal = r * analysis.shape[1] + c
    masks = _move_masks(passable)
    args = (masks, flat_goal, float(diagonal_cost), analysis.clean)
    if not analysis.penalised:
        k = kw = _wave(*args, False)
    elif passable.size < _THREADED_CELLS:
        k = _wave(*args, False)
        kw = _wave(*args, True)
    else:
        # The kernels release the GIL: the two fields run side by side, sharing the masks.
        fields: dict[bool, npt.NDArray[np.float64]] = {}
        worker = threading.Thread(target=lambda: fields.update({False: _wave(*args, False)}))
        worker.start()
        kw = _wave(*args, True)
        worker.join()
        k = fields[False]
    elapsed = (time.perf_counter() - t0) * 1e3
    return Wave(
        (r, c),
        k,
        kw,
        passable,
        narrow=narrow,
        diagonal_cost=float(diagonal_cost),
        elapsed_ms=elapsed,
    )

"""The resumable goal wave: ``k`` and ``kw`` settled only where the robot needs them.

:class:`ResumableWave` is a :class:`~planner.Wave` whose two fields come from A* searches
rooted at the goal and aimed at the robot (RRA*). A decision at a cell reads the cost-to-go of
the cell and its neighbours; :meth:`ResumableWave.ensure` resumes both searches until exactly
those are settled, so a plan's memory and time grow with the region explored, not the map.
Settled values are the whole-map wave's to the last bit, whatever robots the searches were aimed
at: robots sharing a goal may share one wave, each growing it where it goes (one thread at a
time; :meth:`ResumableWave.hold` lets a caller read without waiting and without resuming). The
whole-map arrays (``k``, ``kw``, ``passable``) are still there for pictures and simulations: the
first read computes the whole wave once.
"""

from __future__ import annotations

import functools
import threading
import time
from collections.abc import Callable
from typing import Any, Concatenate, ParamSpec, TypeVar

import numpy as np
import numpy.typing as npt

from planner._errors import InvalidInput, quote
from planner.analysis import _kernels as K
from planner.analysis import _search as S
from planner.analysis.fields import Analysis, Wave, WaveView, goal_wave
from planner.maps.grids import as_cell
from planner.params import PARAMETER_RANGES, SQRT2

__all__ = ["ResumableWave", "Unsettled", "resumable_wave"]

P = ParamSpec("P")
R = TypeVar("R")


class Unsettled(Exception):
    """A held wave (:meth:`ResumableWave.hold`) was asked for what it has not settled."""


def _locked(
    method: Callable[Concatenate[ResumableWave, P], R],
) -> Callable[Concatenate[ResumableWave, P], R]:
    """One thread at a time in the wave: a search resumed in one thread may grow (reallocate)
    the arrays another is reading."""

    def wrapper(self: ResumableWave, /, *args: P.args, **kwargs: P.kwargs) -> R:
        with self._lock:
            return method(self, *args, **kwargs)

    functools.update_wrapper(wrapper, method)
    return wrapper


# The open list is re-keyed for a new robot cell only when the robot has moved this far (octile)
# from the cell it was keyed for: settled values are exact under any consistent heuristic, so an
# older aim costs only some extra expansions, and re-keying costs a pass over the open list.
_REAIM = 8.0

# A search that has settled 1/64 of the map (at least 4096 cells) hands over to the whole-map
# wave: per cell, A* with its binary heap costs about five times the whole wave's bucket queue
# (benchmarks/RESULTS.md), so a far goal costs at most ~20 % more than the whole wave would.
_BUDGET_SHARE = 64
_BUDGET_LEAST = 4096

# A robot on a cell the goal's search has not reached yet may be cut off from the goal (a
# pocket): a search from the robot of at most this many cells finds most pockets at once.
_PROBE = 4096
_POCKETS = 4


class _Search:
    """One field's search (``k`` or, with ``use_clean``, ``kw``) and its tiled memory."""

    def __init__(
        self,
        analysis: Analysis,
        goal: int,
        *,
        sealed: bool,
        use_clean: bool,
        diagonal_cost: float,
        root: int | None = None,
    ) -> None:
        """A search over the cells on the grid and ``goal`` (always passable), from ``root``
        (default: the goal)."""
        H, W = analysis.shape
        self.state = analysis.state
        self.clean = analysis.clean
        self.width = W
        self.goal = goal
        self.sealed = sealed
        self.use_clean = use_clean
        self.diagonal_cost = diagonal_cost
        tiles = ((H + S.TILE_MASK) >> S.SHIFT) * ((W + S.TILE_MASK) >> S.SHIFT)
        self.tile_of = np.full(tiles, -1, dtype=np.int32)
        cap = min(4, tiles)
        self.g = np.empty((cap, S.TILE_CELLS), dtype=np.float64)
        self.status = np.empty((cap, S.TILE_CELLS), dtype=np.uint8)
        self.keys = np.empty((1024, 2), dtype=np.float64)  # rows: f, g
        self.cells = np.empty(1024, dtype=np.int64)
        self.meta = np.zeros(3, dtype=np.int64)
        self.exhausted = False
        self.aim = divmod(goal, W)
        self.slack = 0.0
        S._start(
            self.state, goal if root is None else root, self.tile_of, self.g, self.status,
            self.keys, self.cells, self.meta,
        )  # fmt: skip

    @property
    def nbytes(self) -> int:
        arrays = (self.tile_of, self.g, self.status, self.keys, self.cells, self.meta)
        return sum(int(a.nbytes) for a in arrays)

    def seen(self, cell: int) -> bool:
        """Whether the search has reached ``cell`` (a flat index): queued or settled."""
        r, c = divmod(cell, self.width)
        tiles_w = (self.width + S.TILE_MASK) >> S.SHIFT
        slot = int(self.tile_of[(r >> S.SHIFT) * tiles_w + (c >> S.SHIFT)])
        offset = ((r & S.TILE_MASK) << S.SHIFT) | (c & S.TILE_MASK)
        return slot >= 0 and int(self.status[slot, offset]) != S.UNSEEN

    def done(self, targets: npt.NDArray[np.int64]) -> bool:
        """Whether :meth:`settle` would have nothing to do for ``targets``."""
        return self.exhausted or S._all_settled(self.width, self.tile_of, self.status, targets)

    def values(self, targets: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        out: npt.NDArray[np.float64] = S._settled_values(
            self.width, self.tile_of, self.g, self.status, targets
        )
        return out

    def settle(
        self, targets: npt.NDArray[np.int64], aim: tuple[int, int], slack: float, limit: int
    ) -> bool:
        """Resume until every cell of ``targets`` (on the grid, within ``slack`` of ``aim``) is
        settled or the open list is empty; False, the search left where it was, when that would
        settle more than ``limit`` cells in all."""
        if self.exhausted or S._all_settled(self.width, self.tile_of, self.status, targets):
            return True
        d = self.aim[0] - aim[0], self.aim[1] - aim[1]
        if max(abs(d[0]), abs(d[1])) > _REAIM:
            self.aim, self.slack = aim, slack
            S._rekey(
                self.width, self.diagonal_cost, self.tile_of, self.g, self.status, self.keys,
                self.cells, self.meta, aim[0], aim[1], slack,
            )  # fmt: skip
        tr, tc = self.aim
        while True:
            outcome = S._resume(
                self.state, self.clean, self.sealed, self.use_clean, self.diagonal_cost,
                self.goal, self.tile_of, self.g, self.status, self.keys, self.cells, self.meta,
                targets, tr, tc, self.slack, limit,
            )  # fmt: skip
            if outcome == S.NEED_SPACE:
                self._grow()
                continue
            self.exhausted = outcome == S.EXHAUSTED
            return outcome != S.OVER_BUDGET

    def release(self) -> None:
        """Drop the memory: the whole-map wave answers from now on."""
        self.tile_of = np.empty(0, dtype=np.int32)
        self.g = np.empty((0, S.TILE_CELLS), dtype=np.float64)
        self.status = np.empty((0, S.TILE_CELLS), dtype=np.uint8)
        self.keys = np.empty((0, 2), dtype=np.float64)
        self.cells = np.empty(0, dtype=np.int64)

    def _grow(self) -> None:
        if self.meta[S.HEAP_SIZE] + 8 > self.keys.shape[0]:
            n = 2 * self.keys.shape[0]
            self.keys = np.concatenate([self.keys, np.empty_like(self.keys)])
            self.cells = np.concatenate([self.cells, np.empty_like(self.cells)])
            assert self.keys.shape[0] == n
        used, cap = int(self.meta[S.TILES_USED]), self.g.shape[0]
        if used + 4 > cap and cap < self.tile_of.shape[0]:
            grown = min(2 * cap, self.tile_of.shape[0])
            g = np.empty((grown, S.TILE_CELLS), dtype=np.float64)
            status = np.empty((grown, S.TILE_CELLS), dtype=np.uint8)
            g[:used] = self.g[:used]
            status[:used] = self.status[:used]
            self.g, self.status = g, status


class ResumableWave(Wave):
    """A goal wave settled on demand: see the module's docstring.

    >>> from planner import analyse
    >>> a = analyse([[0] * 40 for _ in range(40)], seal_tunnels=False, clean_weight=0)
    >>> w = resumable_wave(a, [0, 0])
    >>> w.ensure(5, 5)   # the robot's cell and its neighbours settled, few others
    >>> round(w.k_at(5, 5), 3), w.settled_cells < 100
    (7.071, True)
    >>> bool(np.allclose(w.k, goal_wave(a, [0, 0]).k))   # the whole field, computed on demand
    True
    """

    def __init__(
        self, analysis: Analysis, goal: tuple[int, int], *, diagonal_cost: float, narrow: bool
    ) -> None:
        t0 = time.perf_counter()
        self.goal = goal
        self.narrow = narrow
        self.diagonal_cost = diagonal_cost
        self.analysis = analysis
        W = analysis.shape[1]
        self._flat_goal = goal[0] * W + goal[1]
        self._sealed = analysis.seal_tunnels and not narrow
        self._k_search = _Search(
            analysis, self._flat_goal, sealed=self._sealed, use_clean=False,
            diagonal_cost=diagonal_cost,
        )  # fmt: skip
        self._kw_search = self._k_search
        if analysis.penalised:
            self._kw_search = _Search(
                analysis, self._flat_goal, sealed=self._sealed, use_clean=True,
                diagonal_cost=diagonal_cost,
            )  # fmt: skip
        self._whole: Wave | None = None
        self._pockets: list[_Search] = []
        self._lock = threading.RLock()
        self._held = 0
        self.on_resize: Callable[[], None] | None = None
        """Called, in the thread that grew the wave and holding it, whenever :attr:`nbytes`
        changed: a cache that bounds its bytes measures the wave again."""
        self._last_view: tuple[tuple[int, int], WaveView] | None = None
        H = analysis.shape[0]
        self.budget = max(_BUDGET_LEAST, H * W // _BUDGET_SHARE)
        """Cells one search may settle before the wave turns into the whole-map one."""
        self.elapsed_ms = (time.perf_counter() - t0) * 1e3

    # -- the searches ------------------------------------------------------------------------

    @_locked
    def settle(self, cells: Any) -> None:
        """Resume both searches until every given cell (``[row, col]`` rows) on the wave's grid
        is settled (its ``k`` and ``kw`` exact) or proven unreachable."""
        arr = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
        H, W = self.analysis.shape
        for i, (r, c) in enumerate(arr.tolist()):
            if not (0 <= r < H and 0 <= c < W):
                raise InvalidInput(f"cells[{i}] [{r}, {c}] is outside the {H} x {W} map")
        on_grid = [
            r * W + c
            for r, c in arr.tolist()
            if S._passable_at(self.analysis.state, self._sealed, self._flat_goal, r, c)
        ]
        if on_grid:
            flat = np.array(on_grid, dtype=np.int64)
            r0, c0 = int(arr[0, 0]), int(arr[0, 1])
            slack = max(S._octile(r, c, r0, c0, self.diagonal_cost, 0.0) for r, c in arr.tolist())
            self._settle(flat, (r0, c0), slack)

    @_locked
    def ensure(self, r: int, c: int) -> None:
        """Settle what a decision at (r, c) reads: the cell and its statically legal
        neighbours (or find them cut off from the goal: their values are then +inf)."""
        targets = S._neighbourhood(self.analysis.state, self._sealed, self._flat_goal, r, c)
        if targets.size == 0 or self._whole is not None:
            return
        kw = self._kw_search
        if not kw.exhausted and not kw.seen(int(targets[0])) and self._cut_off(r, c):
            return
        self._settle(targets, (r, c), self.diagonal_cost)

    def _cut_off(self, r: int, c: int) -> bool:
        """Whether a small search from (r, c) runs out of cells before reaching the goal: then
        the goal's search need not run through its whole region to prove it. The last pockets
        found are kept (a robot in one asks again at every step)."""
        flat = r * self.analysis.shape[1] + c
        if any(pocket.seen(flat) for pocket in self._pockets):
            return True
        self._searching()
        probe = _Search(
            self.analysis, self._flat_goal, sealed=self._sealed, use_clean=False,
            diagonal_cost=self.diagonal_cost, root=flat,
        )  # fmt: skip
        probe.settle(np.array([self._flat_goal], dtype=np.int64), self.goal, 0.0, _PROBE)
        if probe.exhausted:
            self._pockets = [probe, *self._pockets[: _POCKETS - 1]]
            self._resized()
        return probe.exhausted

    def _settle(self, targets: npt.NDArray[np.int64], aim: tuple[int, int], slack: float) -> None:
        if self._whole is not None:
            return
        if self._held and all(s.done(targets) for s in (self._k_search, self._kw_search)):
            return
        self._searching()
        t0 = time.perf_counter()
        before = self.nbytes
        within = self._k_search.settle(targets, aim, slack, self.budget)
        if within and self._kw_search is not self._k_search:
            within = self._kw_search.settle(targets, aim, slack, self.budget)
        self.elapsed_ms += (time.perf_counter() - t0) * 1e3
        if not within:
            self.whole()
        elif self.nbytes != before:
            self._resized()

    def _resized(self) -> None:
        if self.on_resize is not None:
            self.on_resize()

    @property
    def handed_over(self) -> Wave | None:
        """The whole-map wave once it took over (None while the wave is the searches): a
        reader that needs no settling may read it directly, without taking the wave."""
        return self._whole

    @property
    def resumable(self) -> bool:
        """Whether the wave is still the searches (False once the whole-map wave took over)."""
        return self._whole is None

    @property
    def settled_cells(self) -> int:
        """Cells settled so far by the ``kw`` search (the wider one); the whole map's cells
        once the whole-map wave took over."""
        if self._whole is not None:
            return self.analysis.shape[0] * self.analysis.shape[1]
        return int(self._kw_search.meta[S.SETTLED_COUNT])

    def hold(self) -> bool:
        """Take the wave if no other thread has it, without waiting: True, and until
        :meth:`release` no other thread grows it, while a read here that would resume its
        searches raises :class:`Unsettled` instead (the caller does that work elsewhere: a
        search may take up to the whole-map wave); False, not taken."""
        if not self._lock.acquire(blocking=False):
            return False
        self._held += 1
        return True

    def release(self) -> None:
        """Let go of the wave taken by :meth:`hold`."""
        self._held -= 1
        self._lock.release()

    def _searching(self) -> None:
        if self._held:
            raise Unsettled("the wave would resume its searches")

    def on_grid(self, cells: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
        """Whether each cell (flat indices) is on the wave's grid, without the whole wave."""
        state = self.analysis.state.ravel()[cells]
        on = state == K.FREE if self._sealed else state != K.BLOCKED_CELL
        out: npt.NDArray[np.bool_] = on | (cells == self._flat_goal)
        return out

    # -- what decisions read -----------------------------------------------------------------

    @_locked
    def view(self, r: int, c: int, clean: npt.NDArray[np.float32]) -> WaveView:
        """The 3 x 3 window around (r, c), settled first (``clean`` is the analysis's own)."""
        if self._last_view is not None and self._last_view[0] == (r, c):
            return self._last_view[1]  # settled values never change
        k, kw = self._k_search, self._kw_search
        if self._whole is None and not S._settled_around(
            self.analysis.state, self._sealed, self._flat_goal, r, c, k.tile_of, k.status,
            kw.tile_of, kw.status,
        ):  # fmt: skip
            self.ensure(r, c)
        if self._whole is not None:
            return self._whole.view(r, c, clean)
        passable, kv, kwv, cl = S._window(
            self.analysis.state, self.analysis.clean, self._sealed, self._flat_goal, r, c,
            k.tile_of, k.g, k.status, kw.tile_of, kw.g, kw.status,
        )  # fmt: skip
        view = WaveView(passable, kv, kwv, cl, r - 1, c - 1)
        self._last_view = ((r, c), view)
        return view

    @_locked
    def detour(
        self,
        start: int,
        obstacles: npt.NDArray[np.int64],
        clean: npt.NDArray[np.float32],
        margin: int = 0,
    ) -> npt.NDArray[np.int64]:
        """The replan over what the searches have settled (see ``_search._detour``); past the
        budget of expansions, or on a map no larger than the budget (whose whole-map wave takes
        no more memory than the searches may), over the whole-map wave."""
        H, W = self.analysis.shape
        if self._whole is None:
            self._searching()
        if self._whole is None and self.budget < H * W:
            kw = self._kw_search
            out: npt.NDArray[np.int64]
            out, gave_up = S._detour(
                self.analysis.state, self.analysis.clean, self._sealed, self._flat_goal,
                kw.tile_of, kw.g, kw.status, kw.exhausted, start, self.diagonal_cost,
                obstacles, margin, self.budget,
            )  # fmt: skip
            if not gave_up:
                return out
        return self.whole().detour(start, obstacles, clean, margin)

    @_locked
    def k_at(self, r: int, c: int) -> float:
        W = self.analysis.shape[1]
        flat = np.array([r * W + c], dtype=np.int64)
        if self._whole is None:
            value = float(self._k_search.values(flat)[0])
            if value < np.inf:
                return value  # settled: exact
        if S._passable_at(self.analysis.state, self._sealed, self._flat_goal, r, c):
            k = self._k_search
            unseen = self._whole is None and not k.exhausted and not k.seen(r * W + c)
            if unseen and self._cut_off(r, c):
                return np.inf
            self._settle(flat, (r, c), 0.0)
        if self._whole is not None:
            return self._whole.k_at(r, c)
        return float(self._k_search.values(flat)[0])

    @_locked
    def k_along(self, path: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """``k`` of each cell of ``path`` (``(n, 2)`` cells), settled first."""
        if self._whole is not None:
            return self._whole.k_along(path)
        W = self.analysis.shape[1]
        flat = np.ascontiguousarray(path[:, 0] * W + path[:, 1], dtype=np.int64)
        values = self._k_search.values(flat)
        for j in np.flatnonzero(~np.isfinite(values)).tolist():
            values[j] = self.k_at(int(path[j, 0]), int(path[j, 1]))
        return values

    @_locked
    def walk(
        self, start: tuple[int, int], mode: int, alpha: float, beta: float, max_steps: int
    ) -> npt.NDArray[np.int64]:
        """The path (flat indices) the decision follows with no dynamic obstacles, as
        ``_kernels._walk`` does over whole fields; empty if the goal is not reached."""
        W = self.analysis.shape[1]
        if mode == K.MODE_WIDE:
            return self._walk_wide(start[0] * W + start[1], max_steps)
        gr, gc = self.goal
        clean = self.analysis.clean
        contact = np.zeros(8, dtype=np.int64)
        r, c = start
        path = [r * W + c]
        visited = {path[0]}
        while (r, c) != self.goal:
            if len(path) > max_steps:
                return np.empty(0, dtype=np.int64)
            v = self.view(r, c, clean)
            if self._whole is not None:
                return self._walk_whole(path, visited, mode, alpha, beta, max_steps)
            tabu = 0
            if mode == K.MODE_PAPER:
                for i in range(8):
                    if (r + int(K.DR[i])) * W + c + int(K.DC[i]) in visited:
                        tabu |= 1 << i
            i, outcome = K._decide_core(
                v.passable, v.k, v.kw, v.clean, 1, 1, 0, 0, False, contact, tabu, gr - v.top,
                gc - v.left, mode, alpha, beta, self.diagonal_cost, -1,
            )  # fmt: skip
            if outcome != K.MOVE:
                return np.empty(0, dtype=np.int64)
            r, c = r + int(K.DR[i]), c + int(K.DC[i])
            path.append(r * W + c)
            visited.add(r * W + c)
        return np.array(path, dtype=np.int64)

    def _walk_wide(self, start: int, max_steps: int) -> npt.NDArray[np.int64]:
        """The wide walk in a kernel over the settled cells, the searches resumed wherever it
        finds a neighbourhood unsettled."""
        W = self.analysis.shape[1]
        pieces = []
        x = start
        steps = 0
        while True:
            if self._whole is not None:
                rest = self._walk_whole([x], {x}, K.MODE_WIDE, 0.0, 0.0, max_steps - steps)
                if rest.size == 0:
                    return rest
                pieces.append(rest)
                break
            k, kw = self._k_search, self._kw_search
            piece, why = S._walk_settled(
                self.analysis.state, self.analysis.clean, self._sealed, self._flat_goal,
                k.tile_of, k.g, k.status, kw.tile_of, kw.g, kw.status, x,
                self.diagonal_cost, max_steps - steps,
            )  # fmt: skip
            pieces.append(piece[:-1])
            steps += piece.size - 1
            x = int(piece[-1])
            if why == S.WALK_ARRIVED:
                pieces.append(piece[-1:])
                break
            if why != S.WALK_UNSETTLED:
                return np.empty(0, dtype=np.int64)
            # One step as a session takes it (settling, then deciding over the window): the
            # kernel resumes from the next cell.
            r, c = divmod(x, W)
            v = self.view(r, c, self.analysis.clean)
            i, outcome = K._decide_core(
                v.passable, v.k, v.kw, v.clean, r - v.top, c - v.left, 0, 0, False,
                np.zeros(8, dtype=np.int64), 0, self.goal[0] - v.top, self.goal[1] - v.left,
                K.MODE_WIDE, 0.0, 0.0, self.diagonal_cost, -1,
            )  # fmt: skip
            if outcome != K.MOVE or steps >= max_steps:
                return np.empty(0, dtype=np.int64)
            pieces.append(np.array([x], dtype=np.int64))
            steps += 1
            x = (r + int(K.DR[i])) * W + c + int(K.DC[i])
        return np.concatenate(pieces)

    def _walk_whole(
        self,
        path: list[int],
        visited: set[int],
        mode: int,
        alpha: float,
        beta: float,
        max_steps: int,
    ) -> npt.NDArray[np.int64]:
        """The walk's rest over the whole-map wave; the paper decision's tabu list carries
        over (its cells stay visited)."""
        w = self.whole()
        if mode == K.MODE_PAPER and len(visited) > 1:
            # The kernel keeps its own tabu list from the start only: continue step by step.
            return self._walk_slow(path, visited, mode, alpha, beta, max_steps)
        rest = K._walk(
            w.passable, w.k, w.kw, self.analysis.clean, path[-1], self._flat_goal, mode, alpha,
            beta, self.diagonal_cost, max_steps - len(path) + 1,
        )  # fmt: skip
        if rest.size == 0:
            return rest
        return np.concatenate([np.array(path[:-1], dtype=np.int64), rest])

    def _walk_slow(
        self,
        path: list[int],
        visited: set[int],
        mode: int,
        alpha: float,
        beta: float,
        max_steps: int,
    ) -> npt.NDArray[np.int64]:
        w = self.whole()
        W = self.analysis.shape[1]
        gr, gc = self.goal
        contact = np.zeros(8, dtype=np.int64)
        r, c = divmod(path[-1], W)
        while (r, c) != self.goal:
            if len(path) > max_steps:
                return np.empty(0, dtype=np.int64)
            tabu = 0
            for i in range(8):
                if (r + int(K.DR[i])) * W + c + int(K.DC[i]) in visited:
                    tabu |= 1 << i
            i, outcome = K._decide_core(
                w.passable, w.k, w.kw, self.analysis.clean, r, c, 0, 0, False, contact, tabu, gr,
                gc, mode, alpha, beta, self.diagonal_cost, -1,
            )  # fmt: skip
            if outcome != K.MOVE:
                return np.empty(0, dtype=np.int64)
            r, c = r + int(K.DR[i]), c + int(K.DC[i])
            path.append(r * W + c)
            visited.add(r * W + c)
        return np.array(path, dtype=np.int64)

    # -- the whole-map fields, on demand -----------------------------------------------------

    @_locked
    def whole(self) -> Wave:
        """The whole-map wave of the same goal and grid (computed on first use, then kept in
        place of the searches, whose memory it frees)."""
        if self._whole is None:
            self._searching()
            t0 = time.perf_counter()
            self._whole = goal_wave(
                self.analysis, self.goal, diagonal_cost=self.diagonal_cost, narrow=self.narrow
            )
            self.elapsed_ms += (time.perf_counter() - t0) * 1e3
            self._k_search.release()
            self._kw_search.release()
            self._pockets = []
            self._resized()
        return self._whole

    @property
    def k(self) -> npt.NDArray[np.float64]:
        return self.whole().k

    @property
    def kw(self) -> npt.NDArray[np.float64]:
        return self.whole().kw

    @property
    def passable(self) -> npt.NDArray[np.uint8]:
        return self.whole().passable

    @property
    def shape(self) -> tuple[int, int]:
        return self.analysis.shape

    @property
    def nbytes(self) -> int:
        searches = {id(s): s.nbytes for s in (self._k_search, self._kw_search, *self._pockets)}
        whole = 0 if self._whole is None else self._whole.nbytes
        return sum(searches.values()) + whole


def resumable_wave(
    analysis: Analysis, goal: Any, *, diagonal_cost: float = SQRT2, narrow: bool = False
) -> ResumableWave:
    """A goal wave over ``analysis``'s sealed grid (or, with ``narrow``, the unsealed one) that
    settles cells on demand (:meth:`ResumableWave.ensure`, :meth:`ResumableWave.settle`).

    >>> from planner import analyse
    >>> w = resumable_wave(analyse([[0, 0], [0, 0]], clean_weight=0), [0, 0])
    >>> w.settle([[1, 1]]); round(w.k_at(1, 1), 3)
    1.414
    """
    r, c = as_cell(goal, analysis.shape, name="goal")
    if analysis.state[r, c] == K.BLOCKED_CELL:
        raise InvalidInput(f"goal [{r}, {c}] is on an obstacle", field="goal")
    low, high = PARAMETER_RANGES["diagonal_cost"]
    if not low <= diagonal_cost <= high:
        msg = f"diagonal_cost must be in [{low}, {high}]; got {quote(diagonal_cost)}"
        raise InvalidInput(msg, field="params.diagonal_cost")
    return ResumableWave(analysis, (r, c), diagonal_cost=float(diagonal_cost), narrow=narrow)

"""The resumable goal wave: ``k`` and ``kw`` settled by the goal's searches only where a robot
needs them, exact to the bit, handing over to the whole-map wave past a budget."""

from __future__ import annotations

import functools
import threading
import time
from collections.abc import Callable
from typing import Any, Concatenate, ParamSpec, TypeVar

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.errors import InvalidInput
from planner.params import SQRT2
from planner.plans.decide import MODE_PAPER, MOVE, Rule, decide
from planner.plans.detour import detour_cells
from planner.plans.moves import DC, DR, OPEN_SEALED, OPEN_UNSEALED, octile, on_grid
from planner.plans.pockets import Pockets
from planner.plans.search import SETTLED_COUNT, GoalSearch
from planner.plans.walk import (
    WALK_ARRIVED,
    WALK_TOO_LONG,
    WALK_UNSETTLED,
    neighbourhood,
    settled_around,
    walk_fields,
    walk_settled,
    window,
)
from planner.plans.whole_wave import Cells, Clean, Wave, WaveView, goal_wave, wave_goal

__all__ = ["ResumableWave", "Unsettled", "resumable_wave"]

P = ParamSpec("P")
R = TypeVar("R")
DR_ = [int(v) for v in DR]
DC_ = [int(v) for v in DC]


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


# A search that has settled 1/64 of the map (4096 cells at least) goes on to 1/8 if its headway
# says it is done by then, else hands over to the whole-map wave (a fifth of A*'s cost a cell).
_PROBE_SHARE = 64
_BUDGET_SHARE = 8
_BUDGET_LEAST = 4096


class ResumableWave(Wave):
    """A goal wave settled on demand.

    :meth:`ensure` resumes both searches until what a decision at a cell reads is settled, so a
    plan's memory and time grow with the region explored, not the map. Robots sharing a goal
    may share one wave, each growing it where it goes (one thread at a time; :meth:`hold` lets
    a caller read without waiting and without resuming).

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
        self._open = OPEN_SEALED if analysis.seal_tunnels and not narrow else OPEN_UNSEALED
        self._k_search = GoalSearch(
            analysis, self._flat_goal, open_=self._open, use_clean=False,
            diagonal_cost=diagonal_cost,
        )  # fmt: skip
        self._kw_search = self._k_search
        if analysis.penalised:
            self._kw_search = GoalSearch(
                analysis, self._flat_goal, open_=self._open, use_clean=True,
                diagonal_cost=diagonal_cost,
            )  # fmt: skip
        self._whole: Wave | None = None
        self._pockets = Pockets(analysis, goal, open_=self._open, diagonal_cost=diagonal_cost)
        self._lock = threading.RLock()
        self._held = 0
        self.on_resize: Callable[[], None] | None = None
        """Called, in the thread that grew the wave and holding it, whenever :attr:`nbytes`
        changed: a cache that bounds its bytes measures the wave again."""
        self._last_view: tuple[tuple[int, int], WaveView] | None = None
        H = analysis.shape[0]
        self.budget = max(_BUDGET_LEAST, H * W // _BUDGET_SHARE)
        """Cells one search may settle before the wave turns into the whole-map one, and
        (:attr:`probe`) before it checks its headway (``GoalSearch.settle_paced``)."""
        self.probe = max(_BUDGET_LEAST, H * W // _PROBE_SHARE)
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
        targets = [
            r * W + c
            for r, c in arr.tolist()
            if on_grid(self.analysis.state, self._open, self._flat_goal, r, c)
        ]
        if targets:
            flat = np.array(targets, dtype=np.int64)
            r0, c0 = int(arr[0, 0]), int(arr[0, 1])
            slack = max(octile(r, c, r0, c0, self.diagonal_cost, 0.0) for r, c in arr.tolist())
            self._settle(flat, (r0, c0), slack)

    @_locked
    def ensure(self, r: int, c: int) -> None:
        """Settle what a decision at (r, c) reads: the cell and its statically legal
        neighbours (or find them cut off from the goal: their values are then +inf)."""
        targets = neighbourhood(self.analysis.state, self._open, self._flat_goal, r, c)
        if targets.size == 0 or self._whole is not None:
            return
        kw = self._kw_search
        if not kw.exhausted and not kw.seen(int(targets[0])) and self._cut_off(r, c):
            return
        self._settle(targets, (r, c), self.diagonal_cost)

    def _cut_off(self, r: int, c: int) -> bool:
        """Whether (r, c) is in a pocket cut off from the goal (:mod:`planner.plans.pockets`):
        then the goal's search need not run through its whole region to prove it."""
        flat = r * self.analysis.shape[1] + c
        if self._pockets.holds(flat):
            return True
        self._searching()
        if not self._pockets.probe(flat):
            return False
        self._resized()
        return True

    def _settle(self, targets: npt.NDArray[np.int64], aim: tuple[int, int], slack: float) -> None:
        if self._whole is not None:
            return
        if self._held and all(s.done(targets) for s in (self._k_search, self._kw_search)):
            return
        self._searching()
        t0 = time.perf_counter()
        before = self.nbytes  # ``kw`` first: the looser heuristic's search, the one to run over
        within = self._kw_search.settle_paced(targets, aim, slack, self.probe, self.budget)
        if within and self._kw_search is not self._k_search:
            within = self._k_search.settle_paced(targets, aim, slack, self.probe, self.budget)
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
        return int(self._kw_search.meta[SETTLED_COUNT])

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
        on = (self._open >> self.analysis.state.ravel()[cells]) & 1 == 1
        out: npt.NDArray[np.bool_] = on | (cells == self._flat_goal)
        return out

    # -- what decisions read -----------------------------------------------------------------

    @_locked
    def view(self, r: int, c: int, clean: npt.NDArray[np.float32]) -> WaveView:
        """The 3 x 3 window around (r, c), settled first (``clean`` is the analysis's own)."""
        if self._last_view is not None and self._last_view[0] == (r, c):
            return self._last_view[1]  # settled values never change
        k, kw = self._k_search, self._kw_search
        state, goal = self.analysis.state, self._flat_goal
        if self._whole is None and not settled_around(state, self._open, goal, r, c, (k, kw)):
            self.ensure(r, c)
        if self._whole is not None:
            return self._whole.view(r, c, clean)
        passable, kv, kwv, cl = window(state, self.analysis.clean, self._open, goal, r, c, (k, kw))
        view = WaveView(passable, kv, kwv, cl, r - 1, c - 1)
        self._last_view = ((r, c), view)
        return view

    @_locked
    def detour(
        self,
        start: int,
        obstacles: Cells,
        clean: Clean,
        margin: int = 0,
        within: int | None = None,
    ) -> Cells:
        """The replan over what the searches have settled (:mod:`planner.plans.detour`); past
        :attr:`probe` expansions, or on a map no larger (whose whole-map wave takes no more
        memory than the searches may), over the whole-map wave. With ``within``, bounded to
        that window round ``start`` (see :meth:`Wave.detour`)."""
        H, W = self.analysis.shape
        if self._whole is None:
            self._searching()
        if self._whole is None and self.probe < H * W:
            kw = self._kw_search
            out: npt.NDArray[np.int64]
            out, gave_up = detour_cells(
                self.analysis.state, self._open, self._flat_goal, self.analysis.clean, start,
                obstacles, margin=margin, diagonal_cost=self.diagonal_cost,
                tiles=(kw.tile_of, kw.g, kw.status), exhausted=kw.exhausted, limit=self.probe,
                within=within,
            )  # fmt: skip
            if not gave_up:
                return out
        return self.whole().detour(start, obstacles, clean, margin, within)

    @_locked
    def k_at(self, r: int, c: int) -> float:
        W = self.analysis.shape[1]
        flat = np.array([r * W + c], dtype=np.int64)
        if self._whole is None:
            value = float(self._k_search.values(flat)[0])
            if value < np.inf:
                return value  # settled: exact
        if on_grid(self.analysis.state, self._open, self._flat_goal, r, c):
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
        self, start: tuple[int, int], rule: Rule, max_steps: int, *, partial: bool = False
    ) -> npt.NDArray[np.int64]:
        """The path (flat indices) the decision follows with no dynamic obstacles, as
        :func:`~planner.plans.walk.walk_fields` does over whole fields; empty if the goal is
        not reached (with ``partial``, its first ``max_steps`` moves)."""
        W = self.analysis.shape[1]
        if rule.mode != MODE_PAPER:
            return self._walk_wide(start[0] * W + start[1], rule, max_steps, partial)
        r, c = start
        path = [r * W + c]
        visited = set(path)
        while (r, c) != self.goal:
            if len(path) > max_steps:
                return np.array(path, dtype=np.int64) if partial else np.empty(0, dtype=np.int64)
            if self._whole is not None and len(path) == 1:
                return self._walk_whole(path, rule, max_steps, partial)
            # The paper's tabu list: the cells visited (a move off the map is never legal).
            tabu = sum(1 << i for i in range(8) if (r + DR_[i]) * W + c + DC_[i] in visited)
            i, outcome = self._step(r, c, rule, tabu)
            if outcome != MOVE:
                return np.empty(0, dtype=np.int64)
            r, c = r + DR_[i], c + DC_[i]
            path.append(r * W + c)
            visited.add(r * W + c)
        return np.array(path, dtype=np.int64)

    def _step(self, r: int, c: int, rule: Rule, tabu: int) -> tuple[int, int]:
        """The decision at (r, c) over what the wave settled there (or its whole fields)."""
        v = self.view(r, c, self.analysis.clean)
        return decide(v, (r, c), rule, goal=self.goal, tabu=tabu)

    def _walk_wide(
        self, start: int, rule: Rule, max_steps: int, partial: bool
    ) -> npt.NDArray[np.int64]:
        """The wide walk in a kernel over the settled cells, the searches resumed wherever it
        finds a neighbourhood unsettled."""
        W = self.analysis.shape[1]
        pieces = []
        x = start
        steps = 0
        while True:
            if self._whole is not None:
                rest = self._walk_whole([x], rule, max_steps - steps, partial)
                if rest.size == 0:
                    return rest
                pieces.append(rest)
                break
            piece, why = walk_settled(
                self.analysis.state, self.analysis.clean, self._open, self._flat_goal,
                (self._k_search, self._kw_search), x, diagonal_cost=self.diagonal_cost,
                max_steps=max_steps - steps,
            )  # fmt: skip
            pieces.append(piece[:-1])
            steps += piece.size - 1
            x = int(piece[-1])
            if why == WALK_ARRIVED or (why == WALK_TOO_LONG and partial):
                pieces.append(piece[-1:])
                break
            if why != WALK_UNSETTLED:
                return np.empty(0, dtype=np.int64)
            # One step as a session takes it (settling, then deciding over the window): the
            # kernel resumes from the next cell.
            r, c = divmod(x, W)
            i, outcome = self._step(r, c, rule, 0)
            if outcome != MOVE or steps >= max_steps:
                if outcome == MOVE and partial:
                    pieces.append(np.array([x], dtype=np.int64))
                    break
                return np.empty(0, dtype=np.int64)
            pieces.append(np.array([x], dtype=np.int64))
            steps += 1
            x = (r + DR_[i]) * W + c + DC_[i]
        return np.concatenate(pieces)

    def _walk_whole(
        self, path: list[int], rule: Rule, max_steps: int, partial: bool = False
    ) -> npt.NDArray[np.int64]:
        """The walk's rest from ``path[-1]`` over the whole-map wave (the paper decision's
        kernel keeps its tabu list from there: called with one cell visited)."""
        view = self.whole().view(0, 0, self.analysis.clean)
        steps = max_steps - len(path) + 1
        rest = walk_fields(view, path[-1], self._flat_goal, rule, max_steps=steps, partial=partial)
        if rest.size == 0:
            return rest
        return np.concatenate([np.array(path[:-1], dtype=np.int64), rest])

    @_locked
    def whole(self) -> Wave:
        """The whole-map wave of the same goal and grid (computed on first use, then kept in
        place of the searches, whose memory it frees)."""
        if self._whole is None:
            self._searching()
            t0 = time.perf_counter()
            self._k_search.release()  # first: their memory is not held beside the new fields
            self._kw_search.release()
            self._pockets.clear()
            self._whole = goal_wave(
                self.analysis, self.goal, diagonal_cost=self.diagonal_cost, narrow=self.narrow
            )
            self.elapsed_ms += (time.perf_counter() - t0) * 1e3
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
        searches = {id(s): s.nbytes for s in (self._k_search, self._kw_search)}
        whole = 0 if self._whole is None else self._whole.nbytes
        return sum(searches.values()) + self._pockets.nbytes + whole


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
    r, c = wave_goal(analysis, goal, diagonal_cost)
    return ResumableWave(analysis, (r, c), diagonal_cost=float(diagonal_cost), narrow=narrow)

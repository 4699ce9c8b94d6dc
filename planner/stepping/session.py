"""Stepping among dynamic obstacles (docs/algorithm.md, "Dynamic obstacles and stepping"): one
decision per reported step, from a
plan (heavy, cacheable) and a session state (small, plain data a store keeps as JSON)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.errors import InvalidInput, SequenceConflict, quote
from planner.maps.frames import point_xy
from planner.params import SQRT2
from planner.plans.decide import BLOCKED, EVADE, MODE_PAPER, MOVE, WAIT, Rule, cost_here, decide
from planner.plans.ends import cell_of, end_yaw, free_cell
from planner.plans.moves import DC, DR
from planner.plans.planning import Plan
from planner.plans.reach import route
from planner.stepping.ahead import blocked_ahead, window_cells
from planner.stepping.horizon import path_ahead
from planner.stepping.legs import go_on, last_leg, later_cost, leg_of
from planner.stepping.obstacles import blocked_cells, obstacle_cells
from planner.stepping.replan import unsealed_detour
from planner.stepping.state import MOVES, SessionState, Status, Step

__all__ = ["MOVES", "Session", "SessionState", "Status", "Step"]


class Session:
    """A robot following a plan among dynamic obstacles, one :meth:`step` at a time.

    >>> from planner import plan
    >>> p = plan([[0, 0, 0], [0, 0, 0], [0, 0, 0]], [0, 0], [2, 2], preset="shortest",
    ...          dynamic_margin=0)
    >>> s = Session(p)
    >>> s.step([[1, 1]]).move   # the diagonal is taken: go round
    'E'
    >>> s.step([]).move, s.step([]).status
    ('SE', 'arrived')
    """

    def __init__(
        self, plan: Plan, state: SessionState | None = None, *, poses: bool = True
    ) -> None:
        self.route = plan
        """The plan as given: through waypoints, :attr:`plan` is the leg the robot is on, and
        on arriving at a waypoint the robot goes on with the next leg (``state.leg``)."""
        self.poses = poses
        """Whether each step answers the path ahead (``Step.poses``, ``Step.remaining_m``)."""
        if state is None:
            state = SessionState(position=plan.start, trajectory=[plan.start])
        self.state = state
        self.plan = plan = leg_of(plan, state)
        self._width = plan.analysis.shape[1]
        self._rule = Rule.of(plan.params)
        # The tabu list: only the paper's decision reads it.
        self._visited: set[int] | None = None
        if self._rule.mode == MODE_PAPER:
            w = self._width
            self._visited = {r * w + c for r, c in state.trajectory[state.leg_start :]}

    @property
    def at_goal(self) -> bool:
        """Whether the robot stands on its (last) goal: its next step, without a reported
        position, keeps it there whatever the obstacles (``arrived``, one pose)."""
        return self.state.position == self.plan.goal and last_leg(self.route, self.state)

    @property
    def may_replan(self) -> bool:
        """Whether the next step (without a reported ``position``) may search: an A* search, up
        to the whole map. Any other step is a bounded look at the robot's neighbourhood (and,
        on a detour, a walk down the plan's field), microseconds of work."""
        return self.may_replan_at(None)

    def may_replan_at(self, position: Any = None, obstacles: Any = None) -> bool:
        """:attr:`may_replan` for a step that reports the robot at ``position``: a position off
        the plan's sealed grid (a pocket that sealing closed) is searched out of at once; with
        the step's ``obstacles``, a session making the path ahead searches at once where they
        cut it within the horizon."""
        st = self.state
        cell = st.position
        held, replan_at, on_detour = st.held_up, st.replan_at, bool(st.detour)
        if position is not None:
            try:
                cell = cell_of(self.plan.analysis, position, "position")
            except InvalidInput:
                return False  # the step will refuse it
            if cell != st.position:
                held = replan_at = 0
                on_detour = False
        (gr, gc), last = self.plan.goal, last_leg(self.route, st)
        if cell == (gr, gc):
            return not last  # on to the next leg: it may search
        if not last and max(abs(cell[0] - gr), abs(cell[1] - gc)) <= 1:
            return True  # it may reach the waypoint, then read the next leg's wave
        if st.status == "blocked" and cell == st.position:
            return False
        if self.poses and obstacles is not None and len(obstacles):
            try:
                cells = obstacle_cells(obstacles, self.plan.analysis.shape)
            except InvalidInput:
                return False  # the step will refuse them
            here = st if cell == st.position else SessionState(position=cell)
            if blocked_ahead(self.plan, here, cell, cells) >= 0:
                return True
        return self._may_search(held, replan_at, on_detour or self._on_plan(cell))

    def _may_search(self, held: int, replan_at: int, guided: bool) -> bool:
        """Off the plan's grid with no detour to follow (not ``guided``), the robot searches at
        once and then every ``patience`` steps; else once held up for ``patience`` steps."""
        if not guided:
            return held >= replan_at
        return held >= max(self.plan.params.patience, replan_at)

    def step(
        self,
        dynamic_obstacles: Any = (),
        *,
        position: Any = None,
        seq: int | None = None,
    ) -> Step:
        """Decide and record the next move, given the cells dynamic obstacles occupy now.

        ``position`` is where the robot really is, if the client knows better: a cell, or a
        point ``{"x", "y"}`` in meters, with its heading ``"yaw"`` (radians) if known: the
        answer's ``poses`` start there. ``seq``, when
        given, must be the last step's ``seq`` + 1 (a new step) or the last ``seq`` again (a
        retry: the same answer, the robot not moved twice); the first step may take any ``seq``.
        """
        st = self.state
        if seq is not None:
            if isinstance(seq, bool) or not isinstance(seq, int) or seq < 0:
                raise InvalidInput(
                    f"seq must be a non-negative integer; got {quote(seq)}", field="seq"
                )
            if st.last_seq is not None and seq == st.last_seq and st.last_step is not None:
                return st.last_step
            if st.last_seq is not None and seq != st.last_seq + 1:
                msg = f"seq {seq} does not follow the last step's seq {st.last_seq}"
                raise SequenceConflict(msg, field="seq")
        else:
            seq = 0 if st.last_seq is None else st.last_seq + 1
        obstacles = obstacle_cells(dynamic_obstacles, self.plan.analysis.shape)
        point, yaw = _pose(position)
        if position is not None:
            self._relocate(position)
        self._next_leg()
        step = self._advance(seq, obstacles)
        if step.status == "arrived" and self._next_leg():
            step = dataclasses.replace(step, status=st.status)
        if self.poses:
            poses, remaining_m = path_ahead(
                self.plan, st, step, obstacles, reported=position is not None, point=point,
                yaw=yaw,
            )  # fmt: skip
            if remaining_m is not None:
                remaining_m += later_cost(self.route, st) * self.plan.analysis.frame.resolution
            step = dataclasses.replace(step, poses=poses, remaining_m=remaining_m)
        st.last_seq = seq
        st.last_step = step
        return step

    def _next_leg(self) -> bool:
        """At a waypoint with legs left: on to the next leg (True)."""
        if not go_on(self.route, self.state):
            return False
        self.plan = leg_of(self.route, self.state)
        if self._visited is not None:
            r, c = self.state.position
            self._visited = {r * self._width + c}
        return True

    def _relocate(self, position: Any) -> None:
        st = self.state
        r, c = free_cell(self.plan.analysis, position, "position")
        if (r, c) != st.position:
            st.position = (r, c)
            st.trajectory.append((r, c))
            if self._visited is not None:
                self._visited.add(r * self._width + c)
            st.detour = []
            st.narrow_fallback = False
            st.held_up = st.replan_at = 0
            if st.status in ("arrived", "blocked") and (r, c) != self.plan.goal:
                st.status = "moving"

    def _advance(self, seq: int, obstacles: npt.NDArray[np.int64]) -> Step:
        st = self.state
        plan = self.plan
        previous = st.position
        if previous == plan.goal:
            st.status = "arrived"
            return self._answer(seq, previous, "WAIT")
        st.iteration += 1
        if st.status == "blocked":  # the static map cannot change: only a new position helps
            return self._answer(seq, previous, "WAIT")
        p = plan.params
        on_plan = self._on_plan(previous)
        searching = self._may_search(st.held_up, st.replan_at, bool(st.detour) or on_plan)
        i, outcome = -1, WAIT
        if on_plan and (not st.detour or self._route_clear(previous, obstacles)):
            i, outcome = self._decide(previous, obstacles, -1)
            if outcome == MOVE and st.detour:
                # The blockage that made the detour is gone: back to the plan's better route.
                st.detour = []
                st.narrow_fallback = False
        if st.detour and outcome != MOVE:
            i, outcome = self._decide(previous, obstacles, st.detour[0])
        # The path ahead goes around: the route cut within the horizon, a way round at once.
        ahead = self.poses and (on_plan or bool(st.detour))
        cut = blocked_ahead(plan, st, previous, obstacles) if ahead else -1
        decided, stuck = (i, outcome), -1
        if cut >= 0:
            outcome, searching = WAIT, True
        status: Status = "moving"
        if outcome in (WAIT, BLOCKED) and searching:
            found = self._search(previous, obstacles, on_plan, windowed=cut >= 0)
            if found is None:
                st.status = "blocked"
                st.detour = []
                st.narrow_fallback = False
                return self._answer(seq, previous, "WAIT")
            cells, narrow = found
            if cells.size:
                i = MOVES.index(_move_name(previous, divmod(int(cells[0]), self._width)))
                outcome = MOVE
                st.detour = [int(x) for x in cells]
                st.narrow_fallback = narrow
                st.replans += 1
                status = "replanned"
            else:
                st.replan_at = st.held_up + max(p.patience, 1)
                if cut >= 0:  # no way round: as far as the decision goes towards the cut
                    (i, outcome), stuck = decided, cut
        if outcome in (WAIT, BLOCKED):
            st.held_up += 1
            st.waits += 1
            st.status = "waiting"
            return self._answer(seq, previous, "WAIT", blocked_at=stuck)
        if outcome == EVADE:
            st.detour = []
            st.narrow_fallback = False
        elif st.detour:
            st.detour.pop(0)
        narrow_move = st.narrow_fallback
        if not st.detour:
            st.narrow_fallback = False
        self._move(i)
        st.held_up = st.replan_at = 0
        st.status = "arrived" if st.position == plan.goal else status
        return self._answer(seq, previous, MOVES[i], narrow_move, blocked_at=stuck)

    def _decide(
        self, cell: tuple[int, int], obstacles: npt.NDArray[np.int64], target: int
    ) -> tuple[int, int]:
        plan, p = self.plan, self.plan.params
        wave = plan.wave
        r, c = cell
        tabu = self._tabu(r, c) if self._visited is not None else 0
        # The hook of resumable waves: the view settles what the decision reads, around (r, c).
        v = wave.view(r, c, plan.analysis.clean)
        next_cell = None if target < 0 else divmod(target, self._width)
        return decide(
            v, cell, self._rule, obstacles, goal=plan.goal, margin=p.dynamic_margin, tabu=tabu,
            target=next_cell,
        )  # fmt: skip

    def _on_plan(self, cell: tuple[int, int]) -> bool:
        """Whether the plan's grid leads from ``cell`` to the goal (not a pocket sealing shut)."""
        wave = self.plan.wave
        v = wave.view(cell[0], cell[1], self.plan.analysis.clean)
        r, c = cell[0] - v.top, cell[1] - v.left
        if v.passable[r, c] and v.kw[r, c] < np.inf:  # the usual case, without a kernel call
            return True
        value = cost_here(v, cell, diagonal_cost=wave.diagonal_cost, use_clean=True)
        return bool(np.isfinite(value))

    def _route_clear(self, cell: tuple[int, int], obstacles: npt.NDArray[np.int64]) -> bool:
        """Whether the plan's own route from ``cell`` (the descent of ``kw``) meets no cell that
        the dynamic obstacles block this step."""
        if obstacles.shape[0] == 0:
            return True
        plan = self.plan
        wave, p, W = plan.wave, plan.params, self._width
        H = plan.analysis.shape[0]
        way = route(wave, plan.analysis, cell, plan.goal, Rule.of(p, wide=True))
        if way.size == 0:
            return False
        rows, cols = np.divmod(way, W)
        # The cells entered, and the two cells beside each diagonal move (never squeezed past).
        passed = np.concatenate((way[1:], rows[:-1] * W + cols[1:], rows[1:] * W + cols[:-1]))
        return not np.isin(passed, blocked_cells(obstacles, p.dynamic_margin, (H, W))).any()

    def _search(
        self,
        cell: tuple[int, int],
        obstacles: npt.NDArray[np.int64],
        on_plan: bool,
        *,
        windowed: bool = False,
    ) -> tuple[npt.NDArray[np.int64], bool] | None:
        """The replan: a detour over the plan's grid (``windowed``: first a search of the window
        round the robot, ending where the wave takes over), else one through the sealed tunnels (the
        narrow fallback, applied from here). Returns (cells, narrow), with no cells when the
        dynamic obstacles cut every way for now, or None when no way exists at all."""
        plan = self.plan
        a, wave, p, W = plan.analysis, plan.wave, plan.params, self._width
        start = cell[0] * W + cell[1]
        goal = plan.goal[0] * W + plan.goal[1]
        if on_plan:
            # Over the plan's own wave: a resumable one searches what it has settled.
            within = window_cells(plan) if windowed else None
            cells = wave.detour(start, obstacles, a.clean, p.dynamic_margin, within)
            if cells.size:
                return cells, False
            if windowed:
                # No way round near the robot: a longer one over the whole map, searched as a
                # held-up robot searches (every `patience` steps while none is found).
                if self.state.held_up < self.state.replan_at:
                    return np.empty(0, dtype=np.int64), False
                cells = wave.detour(start, obstacles, a.clean, p.dynamic_margin)
                if cells.size:
                    return cells, False
        if not (a.sealed and not wave.narrow):
            return (np.empty(0, dtype=np.int64), False) if on_plan else None
        # Over the unsealed grid with the octile heuristic: the wave's fields are not read (a
        # resumable wave stays resumable).
        cells = unsealed_detour(a, start, goal, obstacles, p.dynamic_margin, p.diagonal_cost)
        if cells.size:
            sealed = ~wave.on_grid(np.append(cells, start))
            return cells, bool(sealed.any())
        if not on_plan:
            none = np.empty((0, 2), dtype=np.int64)
            way = unsealed_detour(a, start, goal, none, 0, p.diagonal_cost)
            if way.size == 0:
                return None
        return np.empty(0, dtype=np.int64), False

    def _tabu(self, r: int, c: int) -> int:
        H, W = self.plan.analysis.shape
        visited = self._visited
        assert visited is not None
        tabu = 0
        for i in range(8):
            yr, yc = r + int(DR[i]), c + int(DC[i])
            if 0 <= yr < H and 0 <= yc < W and yr * W + yc in visited:
                tabu |= 1 << i
        return tabu

    def _move(self, i: int) -> None:
        st = self.state
        r, c = st.position
        nr, nc = r + int(DR[i]), c + int(DC[i])
        st.position = (nr, nc)
        st.trajectory.append((nr, nc))
        if self._visited is not None:
            self._visited.add(nr * self._width + nc)
        st.path_length += SQRT2 if i & 1 else 1.0  # a length: the diagonal_cost weighs searches
        # A cell the plan's grid seals (or cuts off from the goal) has no k: it counts its
        # cost-to-go along the narrow way the robot follows (what k is: the cost to go from there).
        k = self.plan.wave.k_at(nr, nc)
        st.arc_cost += k if k < np.inf else self.remaining() or 0.0

    def _answer(
        self,
        seq: int,
        previous: tuple[int, int],
        move: str,
        narrow: bool | None = None,
        *,
        blocked_at: int = -1,
    ) -> Step:
        """The step's answer; ``blocked_at``: the flat cell where the way ahead is cut, if it
        is (its center in meters is the answer's ``blocked_at``)."""
        st = self.state
        if narrow is None:
            narrow = st.narrow_fallback
        point = None
        if blocked_at >= 0:
            x, y = self.plan.analysis.frame.centers([divmod(blocked_at, self._width)])[0]
            point = (float(x), float(y))
        return Step(
            seq=seq,
            previous=previous,
            position=st.position,
            move=move,
            status=st.status,
            iteration=st.iteration,
            path_length=st.path_length,
            arc_cost=st.arc_cost,
            remaining=self._to_go(),
            narrow_fallback=self.plan.narrow_fallback or narrow,
            blocked_at=point,
        )

    def _to_go(self) -> float | None:
        """:meth:`remaining`, and through waypoints the legs after this one too."""
        value = self.remaining()
        return None if value is None else value + later_cost(self.route, self.state)

    def remaining(self) -> float | None:
        """Plain cost-to-go ``k`` from the robot's cell, or None when the goal is out of reach;
        off the plan's grid, the length of the detour the robot follows out."""
        wave = self.plan.wave
        st = self.state
        r, c = st.position
        # The hook of resumable waves: the view settles what is read, around (r, c).
        v = wave.view(r, c, self.plan.analysis.clean)
        value = cost_here(v, (r, c), diagonal_cost=wave.diagonal_cost, use_clean=False)
        if np.isfinite(value):
            return value
        if st.detour:
            route = np.array([st.position, *(divmod(x, self._width) for x in st.detour)])
            steps = np.abs(np.diff(route, axis=0)).sum(axis=1)
            return float(
                np.count_nonzero(steps == 1) + np.count_nonzero(steps == 2) * wave.diagonal_cost
            )
        return None


def _pose(position: Any) -> tuple[tuple[float, float] | None, float | None]:
    """A reported point and its heading, if the position is a point (a cell has neither)."""
    if not isinstance(position, Mapping):
        return None, None
    return point_xy(position, name="position"), end_yaw(position, "position")


def _move_name(a: tuple[int, int], b: tuple[int, int]) -> str:
    dr, dc = b[0] - a[0], b[1] - a[1]
    for i in range(8):
        if int(DR[i]) == dr and int(DC[i]) == dc:
            return MOVES[i]
    raise AssertionError(f"{a} -> {b} is not a move")

"""Stepping among dynamic obstacles (ALGORITHM.md §4): one decision per reported step.

A :class:`Session` pairs a :class:`~planner.planning.Plan` (heavy, cacheable arrays) with a
:class:`SessionState` (small, plain data that a store can keep as JSON), so a session can be
rebuilt anywhere from the plan's inputs and its state.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from planner import _kernels as K
from planner._errors import InvalidInput, SequenceConflict, quote
from planner.analysis import WaveView
from planner.grids import as_cell
from planner.planning import Plan

__all__ = ["MOVES", "Session", "SessionState", "Status", "Step"]

#: Move names by kernel move index; ``WAIT`` stays put.
MOVES = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")

Status = Literal["ready", "moving", "waiting", "replanned", "arrived", "blocked"]


@dataclass(frozen=True, slots=True)
class Step:
    """The answer to one step: where the robot goes now and how the episode stands."""

    seq: int
    previous: tuple[int, int]
    position: tuple[int, int]
    move: str
    status: Status
    iteration: int
    path_length: float
    arc_cost: float
    remaining: float | None
    """Plain cost-to-go ``k`` from ``position`` (None when the goal cannot be reached)."""

    def as_dict(self) -> dict[str, Any]:
        return {
            "seq": self.seq,
            "previous": list(self.previous),
            "position": list(self.position),
            "move": self.move,
            "status": self.status,
            "iteration": self.iteration,
            "path_length": self.path_length,
            "arc_cost": self.arc_cost,
            "remaining": self.remaining,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Step:
        return cls(**{**d, "previous": tuple(d["previous"]), "position": tuple(d["position"])})


@dataclass(slots=True)
class SessionState:
    """Everything that changes as the robot steps; JSON-ready through :meth:`as_dict` (cells as
    tuples, which every JSON encoder writes as arrays: the trajectory grows with the episode,
    and a service writes the state back after every step)."""

    position: tuple[int, int]
    status: Status = "ready"
    iteration: int = 0
    path_length: float = 0.0
    arc_cost: float = 0.0
    held_up: int = 0
    replan_at: int = 0
    waits: int = 0
    replans: int = 0
    detour: list[int] = field(default_factory=list)
    trajectory: list[tuple[int, int]] = field(default_factory=list)
    last_seq: int | None = None
    last_step: Step | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "position": list(self.position),
            "status": self.status,
            "iteration": self.iteration,
            "path_length": self.path_length,
            "arc_cost": self.arc_cost,
            "held_up": self.held_up,
            "replan_at": self.replan_at,
            "waits": self.waits,
            "replans": self.replans,
            "detour": list(self.detour),
            "trajectory": list(self.trajectory),
            "last_seq": self.last_seq,
            "last_step": None if self.last_step is None else self.last_step.as_dict(),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SessionState:
        last = d.get("last_step")
        return cls(
            **{
                **d,
                "position": tuple(d["position"]),
                "detour": list(d["detour"]),
                "trajectory": list(map(tuple, d["trajectory"])),
                "last_step": None if last is None else Step.from_dict(last),
            }
        )


class Session:
    """A robot following a plan among dynamic obstacles, one :meth:`step` at a time.

    >>> from planner import plan
    >>> s = Session(plan([[0, 0, 0], [0, 0, 0], [0, 0, 0]], [0, 0], [2, 2], preset="shortest"))
    >>> s.step([[1, 1]]).move   # the diagonal is taken: go round
    'E'
    >>> s.step([]).move, s.step([]).status
    ('SE', 'arrived')
    """

    def __init__(self, plan: Plan, state: SessionState | None = None) -> None:
        self.plan = plan
        if state is None:
            state = SessionState(position=plan.start, trajectory=[plan.start])
        self.state = state
        self._width = plan.analysis.shape[1]
        self._mode = K.MODE_PAPER if plan.params.decision == "paper" else K.MODE_WIDE
        # The tabu list: only the paper's decision reads it.
        self._visited: set[int] | None = None
        if self._mode == K.MODE_PAPER:
            w = self._width
            self._visited = {r * w + c for r, c in state.trajectory}

    @property
    def may_replan(self) -> bool:
        """Whether the next step may run the replan (an A* search, up to the whole map); any
        other step is a bounded look at the robot's neighbourhood, microseconds of work."""
        st = self.state
        return st.held_up >= max(self.plan.params.patience, st.replan_at)

    def step(
        self,
        dynamic_obstacles: Any = (),
        *,
        position: Any = None,
        seq: int | None = None,
    ) -> Step:
        """Decide and record the next move, given the cells dynamic obstacles occupy now.

        ``position`` is where the robot really is, if the client knows better. ``seq``, when
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
        obstacles = self._obstacles(dynamic_obstacles)
        if position is not None:
            self._relocate(position)
        step = self._advance(seq, obstacles)
        st.last_seq = seq
        st.last_step = step
        return step

    def _obstacles(self, cells: Any) -> npt.NDArray[np.int64]:
        try:
            obstacles = np.asarray(cells, dtype=np.int64)
        except (TypeError, ValueError, OverflowError):
            msg = f"dynamic_obstacles must be a list of [row, col] cells; got {quote(cells)}"
            raise InvalidInput(msg, field="dynamic_obstacles") from None
        if obstacles.size == 0:
            return np.empty((0, 2), dtype=np.int64)
        if obstacles.ndim != 2 or obstacles.shape[1] != 2:
            msg = (
                f"dynamic_obstacles must be a list of [row, col] cells; got shape {obstacles.shape}"
            )
            raise InvalidInput(msg, field="dynamic_obstacles")
        H, W = self.plan.analysis.shape
        outside = (obstacles[:, 0] < 0) | (obstacles[:, 0] >= H)
        outside |= (obstacles[:, 1] < 0) | (obstacles[:, 1] >= W)
        if outside.any():
            i = int(np.flatnonzero(outside)[0])
            cell = obstacles[i].tolist()
            msg = f"dynamic_obstacles[{i}] {cell} is outside the {H} x {W} map"
            raise InvalidInput(msg, field="dynamic_obstacles")
        return np.ascontiguousarray(obstacles)

    def _relocate(self, position: Any) -> None:
        st = self.state
        r, c = as_cell(position, self.plan.analysis.shape, name="position")
        if self.plan.analysis.state[r, c] == K.OBSTACLE:
            raise InvalidInput(f"position [{r}, {c}] is on an obstacle", field="position")
        if (r, c) != st.position:
            st.position = (r, c)
            st.trajectory.append((r, c))
            if self._visited is not None:
                self._visited.add(r * self._width + c)
            st.detour = []
            st.held_up = st.replan_at = 0
            if st.status == "arrived" and (r, c) != self.plan.goal:
                st.status = "moving"

    def _advance(self, seq: int, obstacles: npt.NDArray[np.int64]) -> Step:
        st = self.state
        plan = self.plan
        previous = st.position
        if previous == plan.goal:
            st.status = "arrived"
            return self._answer(seq, previous, "WAIT")
        st.iteration += 1
        wave = plan.wave
        p = plan.params
        r, c = previous
        tabu = self._tabu(r, c) if self._visited is not None else 0
        target = st.detour[0] if st.detour else -1
        # The hook of resumable waves: the view settles what the decision reads, around (r, c).
        v = wave.view(r, c, plan.analysis.clean)
        # A window of the map (not the map itself): cells and flat indices are relative to it.
        windowed = bool(v.top or v.left) or v.passable.shape != plan.analysis.shape
        if windowed:
            obstacles = obstacles - np.array([v.top, v.left], dtype=np.int64)
            target = _local(target, self._width, v)
        i, outcome = K._decide(
            v.passable, v.k, v.kw, v.clean, r - v.top, c - v.left, obstacles, tabu,
            plan.goal[0] - v.top, plan.goal[1] - v.left, self._mode, p.alpha, p.beta,
            p.diagonal_cost, target,
        )  # fmt: skip
        if windowed:
            obstacles = obstacles + np.array([v.top, v.left], dtype=np.int64)
        if outcome == K.BLOCKED:
            st.status = "blocked"
            return self._answer(seq, previous, "WAIT")
        status: Status = "moving"
        if outcome == K.WAIT and self.may_replan:
            detour = wave.detour(r * self._width + c, obstacles, plan.analysis.clean)
            if detour.size:
                nxt = int(detour[0])
                i = MOVES.index(_move_name(previous, divmod(nxt, self._width)))
                outcome = K.MOVE
                st.detour = [int(x) for x in detour]
                st.replans += 1
                status = "replanned"
            else:
                st.replan_at = st.held_up + max(p.patience, 1)
        if outcome == K.WAIT:
            st.held_up += 1
            st.waits += 1
            st.status = "waiting"
            return self._answer(seq, previous, "WAIT")
        if outcome == K.EVADE:
            st.detour = []
        elif st.detour:
            st.detour.pop(0)
        self._move(i)
        st.held_up = st.replan_at = 0
        st.status = "arrived" if st.position == plan.goal else status
        return self._answer(seq, previous, MOVES[i])

    def _tabu(self, r: int, c: int) -> int:
        H, W = self.plan.analysis.shape
        visited = self._visited
        assert visited is not None
        tabu = 0
        for i in range(8):
            yr, yc = r + int(K.DR[i]), c + int(K.DC[i])
            if 0 <= yr < H and 0 <= yc < W and yr * W + yc in visited:
                tabu |= 1 << i
        return tabu

    def _move(self, i: int) -> None:
        st = self.state
        r, c = st.position
        nr, nc = r + int(K.DR[i]), c + int(K.DC[i])
        st.position = (nr, nc)
        st.trajectory.append((nr, nc))
        if self._visited is not None:
            self._visited.add(nr * self._width + nc)
        st.path_length += self.plan.params.diagonal_cost if i & 1 else 1.0
        st.arc_cost += self.plan.wave.k_at(nr, nc)

    def _answer(self, seq: int, previous: tuple[int, int], move: str) -> Step:
        st = self.state
        return Step(
            seq=seq,
            previous=previous,
            position=st.position,
            move=move,
            status=st.status,
            iteration=st.iteration,
            path_length=st.path_length,
            arc_cost=st.arc_cost,
            remaining=self.remaining(),
        )

    def remaining(self) -> float | None:
        """Plain cost-to-go ``k`` from the robot's cell, or None when the goal is out of reach."""
        wave = self.plan.wave
        r, c = self.state.position
        v = wave.view(r, c, self.plan.analysis.clean)
        value = K._cost_here(
            v.passable, v.k, v.clean, r - v.top, c - v.left, wave.diagonal_cost, False
        )
        return value if np.isfinite(value) else None


def _local(target: int, width: int, v: WaveView) -> int:
    """A flat map index as the flat index into the view's window (one past it when outside)."""
    if target < 0:
        return target
    h, w = int(v.passable.shape[0]), int(v.passable.shape[1])
    r, c = target // width - v.top, target % width - v.left
    return r * w + c if 0 <= r < h and 0 <= c < w else h * w


def _move_name(a: tuple[int, int], b: tuple[int, int]) -> str:
    dr, dc = b[0] - a[0], b[1] - a[1]
    for i in range(8):
        if int(K.DR[i]) == dr and int(K.DC[i]) == dc:
            return MOVES[i]
    raise AssertionError(f"{a} -> {b} is not a move")

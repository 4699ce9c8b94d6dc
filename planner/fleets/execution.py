"""Executing a fleet's joint plan by its order, not its times: an action dependency graph
(Hönig et al., "Persistent and Robust Execution of MAPF Schedules in Warehouses", 2019).

Each robot's moves follow one another; a move also waits until every move of another robot that
the plan puts earlier at the same place is done. On the roadmap two robots can only meet at a
shared node (disjoint nodes and edges are kept apart by construction), so "the same place" is:
a move into node ``v`` waits for the other robots' last moves out of ``v`` that the plan starts
no later. Off the roadmap (a robot joining from its start, or one still finishing a move when
the fleet was solved again) the place is the move's segment, compared by distance. Every
dependency points from an earlier plan time to a later one, so waits never form a cycle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["Done", "Move", "Schedule", "schedule", "segment_distances", "timed_moves"]

Move = tuple[int, int, int]
"""A move: its source node, its target node and the plan time it starts at (negative for the
moves a robot was already told when the fleet was solved)."""


class Done(Protocol):
    """How many moves each robot has done, by its index in the schedule (a list will do)."""

    def __getitem__(self, robot: int, /) -> int: ...


@dataclass(frozen=True, slots=True)
class Schedule:
    """Each robot's moves and, per move, the moves of other robots it waits for."""

    moves: tuple[tuple[Move, ...], ...]
    after: tuple[tuple[tuple[tuple[int, int], ...], ...], ...]
    """``after[j][k]``: the ``(robot, move)`` pairs robot ``j``'s move ``k`` waits for."""

    def blocker(self, robot: int, move: int, done: Done) -> int | None:
        """The first robot whose move robot ``robot``'s move ``move`` still waits for (None: it
        may go), given how many moves each robot has done."""
        for other, index in self.after[robot][move]:
            if done[other] <= index:
                return other
        return None

    def ready(self, robot: int, start: int, done: Done) -> tuple[int, int | None]:
        """How far robot ``robot`` may go from its move ``start`` on: the index after its last
        move whose predecessors are all done, and the robot it then waits for (None: none, its
        moves are all allowed)."""
        moves = self.moves[robot]
        k = start
        while k < len(moves):
            other = self.blocker(robot, k, done)
            if other is not None:
                return k, other
            k += 1
        return k, None


def timed_moves(paths: npt.NDArray[np.int64], pending: Sequence[Sequence[int]]) -> list[list[Move]]:
    """Each robot's moves in a joint plan: ``paths`` (``(T + 1, k)``: each robot's node at each
    time) with waits left out, after the moves of ``pending[j]`` (the nodes robot ``j`` was
    already told to go through before its first node in ``paths``: moves it may still be
    making, at negative times)."""
    steps, agents = paths.shape
    moves: list[list[Move]] = []
    for j in range(agents):
        chain = list(pending[j]) if j < len(pending) else []
        first = int(paths[0, j])
        if not chain or chain[-1] != first:
            chain.append(first)
        own: list[Move] = [
            (chain[m], chain[m + 1], m - (len(chain) - 1)) for m in range(len(chain) - 1)
        ]
        for t in range(steps - 1):
            u, v = int(paths[t, j]), int(paths[t + 1, j])
            if u != v:
                own.append((u, v, t))
        moves.append(own)
    return moves


def schedule(
    moves: Sequence[Sequence[Sequence[int]]],
    points: npt.NDArray[np.float64],
    *,
    roadmap_nodes: int,
    reach: float,
) -> Schedule:
    """The schedule of each robot's ``moves`` (source, target, plan time) over nodes at
    ``points`` (``(n, 2)``, cells; nodes from ``roadmap_nodes`` on are places off the roadmap).
    ``reach`` (cells) is the distance two robots must keep: an off-roadmap move is waited for by
    the later moves of others that come closer."""
    timed = [[(int(u), int(v), int(t)) for u, v, t in own] for own in moves]
    # Moves out of each roadmap node, by start time; moves off the roadmap, as segments.
    leaving: dict[int, list[tuple[int, int, int]]] = {}
    off: list[tuple[int, int, int, int]] = []  # robot, move index, source, target
    for j, own in enumerate(timed):
        for k, (u, v, t) in enumerate(own):
            if u >= roadmap_nodes or v >= roadmap_nodes:
                off.append((j, k, u, v))
            else:
                leaving.setdefault(u, []).append((t, j, k))
    after: list[list[set[tuple[int, int]]]] = [[set() for _ in own] for own in timed]
    for j, own in enumerate(timed):
        for k, (_, v, t) in enumerate(own):
            last: dict[int, int] = {}
            for t2, i, k2 in leaving.get(v, ()):
                if i != j and t2 <= t and k2 > last.get(i, -1):
                    last[i] = k2
            after[j][k].update(last.items())
    if off:
        _wait_for_off_roadmap(timed, off, after, points, reach)
    return Schedule(
        tuple(tuple(own) for own in timed),
        tuple(tuple(tuple(sorted(deps)) for deps in own) for own in after),
    )


def _wait_for_off_roadmap(
    moves: Sequence[Sequence[Move]],
    off: list[tuple[int, int, int, int]],
    after: list[list[set[tuple[int, int]]]],
    points: npt.NDArray[np.float64],
    reach: float,
) -> None:
    """Every later move (by plan time) of another robot that comes within ``reach`` of an
    off-roadmap move (its segment) waits for that move."""
    owner, index, sources, targets, times = [], [], [], [], []
    for j, own in enumerate(moves):
        for k, (u, v, t) in enumerate(own):
            owner.append(j)
            index.append(k)
            sources.append(u)
            targets.append(v)
            times.append(t)
    a, b = points[np.asarray(sources)], points[np.asarray(targets)]
    robots, when = np.asarray(owner), np.asarray(times)
    for i, k2, u, v in off:
        near = segment_distances(points[u], points[v], a, b) < reach
        later = when > moves[i][k2][2]
        for m in np.nonzero(near & later & (robots != i))[0]:
            after[owner[m]][index[m]].add((i, k2))


def segment_distances(
    p: npt.ArrayLike, q: npt.ArrayLike, a: npt.ArrayLike, b: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    """The distance between segment ``p``-``q`` and each segment ``a[i]``-``b[i]`` (points
    ``(2,)``, ``(2,)``, ``(m, 2)``, ``(m, 2)``; a segment may be a point), exactly: the closest
    points by clamped parameters (Ericson, "Real-Time Collision Detection", 5.1.9).

    >>> ends = [[1.0, 3.0], [4.0, 0.0]]
    >>> segment_distances([0.0, 0.0], [2.0, 0.0], [[1.0, 1.0], [3.0, 0.0]], ends)
    array([1., 1.])
    """
    p_ = np.asarray(p, dtype=np.float64).reshape(2)
    q_ = np.asarray(q, dtype=np.float64).reshape(2)
    a_ = np.ascontiguousarray(a, dtype=np.float64).reshape(-1, 2)
    b_ = np.ascontiguousarray(b, dtype=np.float64).reshape(-1, 2)
    if a_.shape != b_.shape:
        msg = f"a and b: segments' ends of one shape expected; {a_.shape!r} and {b_.shape!r} given"
        raise ValueError(msg)
    out: npt.NDArray[np.float64] = _segment_distances(p_[0], p_[1], q_[0], q_[1], a_, b_)
    return out


@njit(cache=True, nogil=True)
def _segment_distances(
    px: float,
    py: float,
    qx: float,
    qy: float,
    a: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]:
    out = np.empty(a.shape[0], dtype=np.float64)
    d1x, d1y = qx - px, qy - py
    aa = d1x * d1x + d1y * d1y
    eps = 1e-12
    for i in range(a.shape[0]):
        d2x, d2y = b[i, 0] - a[i, 0], b[i, 1] - a[i, 1]
        rx, ry = px - a[i, 0], py - a[i, 1]
        e = d2x * d2x + d2y * d2y
        f = d2x * rx + d2y * ry
        if aa <= eps and e <= eps:
            s, t = 0.0, 0.0
        elif aa <= eps:
            s, t = 0.0, min(max(f / e, 0.0), 1.0)
        else:
            c = d1x * rx + d1y * ry
            if e <= eps:
                s, t = min(max(-c / aa, 0.0), 1.0), 0.0
            else:
                bb = d1x * d2x + d1y * d2y
                denom = aa * e - bb * bb
                s = min(max((bb * f - c * e) / denom, 0.0), 1.0) if denom > eps else 0.0
                t = (bb * s + f) / e
                if t < 0.0:
                    t, s = 0.0, min(max(-c / aa, 0.0), 1.0)
                elif t > 1.0:
                    t, s = 1.0, min(max((bb - c) / aa, 0.0), 1.0)
        dx = (px + s * d1x) - (a[i, 0] + t * d2x)
        dy = (py + s * d1y) - (a[i, 1] + t * d2y)
        out[i] = math.sqrt(dx * dx + dy * dy)
    return out

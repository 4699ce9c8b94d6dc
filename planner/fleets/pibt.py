"""PIBT (Okumura et al., priority inheritance with backtracking): the next configuration of a
fleet from the current one in one pass over the agents, the configuration generator of LaCAM.
Some agents' next nodes may be fixed in advance (LaCAM's low-level constraints)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.fleets.graph import Graph

__all__ = ["Pibt", "tie_breaker"]

_PRIME = 2147483647  # 2**31 - 1: every product below stays under 2**63, so nothing overflows


@njit(cache=True, nogil=True)
def tie_breaker(node: int, salt: int) -> int:
    """A pseudo-random integer in [0, 2**31) of ``node`` and ``salt`` (0..2**62): PIBT's seeded
    tie-break between next nodes equally near an agent's goal, the same in numba and Python."""
    x = (node * 48271 + salt) % _PRIME
    x = (x * 16807 + (salt >> 31)) % _PRIME
    return int((x * 1103515245 + 12345) % _PRIME)


@njit(cache=True, nogil=True)
def _candidates(
    indptr: np.ndarray, indices: np.ndarray, pref: np.ndarray, v: int, salt: int, out: np.ndarray
) -> int:
    """Writes ``v``'s neighbours and ``v`` into ``out`` nearest first by ``pref`` (ties by
    ``tie_breaker``); answers how many."""
    count = 0
    for e in range(indptr[v], indptr[v + 1] + 1):
        u = indices[e] if e < indptr[v + 1] else v
        d, t = pref[u], tie_breaker(u, salt)
        j = count
        while j > 0 and (
            pref[out[j - 1]] > d or (pref[out[j - 1]] == d and tie_breaker(out[j - 1], salt) > t)
        ):
            out[j] = out[j - 1]
            j -= 1
        out[j] = u
        count += 1
    return count


@njit(cache=True, nogil=True)
def _corridor_end(
    indptr: np.ndarray,
    indices: np.ndarray,
    goals: np.ndarray,
    now: np.ndarray,
    behind: int,
    ahead: int,
) -> tuple[int, int]:
    """One step along a corridor from ``behind`` through ``ahead``: ``(count, next)`` where
    ``count`` is how many ways lead on from ``ahead`` (not back, not into a dead end held by an
    agent at its goal) and ``next`` the last of them."""
    count, onward = 0, -1
    for e in range(indptr[ahead], indptr[ahead + 1]):
        u = indices[e]
        a = now[u]
        if u == behind or (indptr[u + 1] - indptr[u] == 1 and a >= 0 and goals[a] == u):
            continue
        count += 1
        onward = u
    return count, onward


@njit(cache=True, nogil=True)
def _swap_required(
    indptr: np.ndarray,
    indices: np.ndarray,
    pref: np.ndarray,
    goals: np.ndarray,
    now: np.ndarray,
    pusher: int,
    puller: int,
    v_pusher: int,
    v_puller: int,
) -> bool:
    """Whether ``pusher`` (at ``v_pusher``) heading through ``puller`` (at ``v_puller``) meets it
    head-on in a corridor with no place to pass before the corridor turns away."""
    while pref[pusher, v_puller] < pref[pusher, v_pusher]:
        count, onward = _corridor_end(indptr, indices, goals, now, v_pusher, v_puller)
        if count >= 2:
            return False  # room to pass at v_puller
        if count == 0:
            break
        v_pusher, v_puller = v_puller, onward
    return bool(
        pref[puller, v_pusher] < pref[puller, v_puller]
        and (pref[pusher, v_pusher] == 0.0 or pref[pusher, v_puller] < pref[pusher, v_pusher])
    )


@njit(cache=True, nogil=True)
def _swap_possible(
    indptr: np.ndarray, indices: np.ndarray, goals: np.ndarray, now: np.ndarray, v: int, w: int
) -> bool:
    """Whether backing from ``w`` away from ``v`` reaches a place to pass (a fork)."""
    behind, ahead = v, w
    while ahead != v:
        count, onward = _corridor_end(indptr, indices, goals, now, behind, ahead)
        if count >= 2:
            return True
        if count == 0:
            return False
        behind, ahead = ahead, onward
    return False


@njit(cache=True, nogil=True)
def _swap_partner(
    indptr: np.ndarray,
    indices: np.ndarray,
    pref: np.ndarray,
    goals: np.ndarray,
    q_from: np.ndarray,
    q_to: np.ndarray,
    now: np.ndarray,
    i: int,
    best: int,
) -> int:
    """The agent ``i`` should swap with (LaCAM3's swap technique: back off and pull it through)
    when its way to ``best`` is a corridor held head-on by that agent, else -1."""
    v = q_from[i]
    j = now[best]
    if (
        j >= 0
        and j != i
        and q_to[j] < 0
        and _swap_required(indptr, indices, pref, goals, now, i, j, v, best)
        and _swap_possible(indptr, indices, goals, now, best, v)
    ):
        return int(j)
    if best != v:  # clear the way for an agent behind i
        for e in range(indptr[v], indptr[v + 1]):
            a = now[indices[e]]
            if (
                a >= 0
                and best != q_from[a]
                and _swap_required(indptr, indices, pref, goals, now, a, i, v, best)
                and _swap_possible(indptr, indices, goals, now, best, v)
            ):
                return int(a)
    return -1


@njit(cache=True, nogil=True)
def _closes_cycle(i: int, j: int, q_from: np.ndarray, q_to: np.ndarray, now: np.ndarray) -> bool:
    """Whether agent ``i`` moving into agent ``j``'s node closes a rotation: following who moves
    into whose node from ``j`` leads back to ``i``. A fleet executes its plan by the order of
    its moves (planner.fleets.execution), and robots rotating at once can never do that."""
    a = j
    for _ in range(q_from.shape[0]):
        t = q_to[a]
        if t < 0 or t == q_from[a]:
            return False
        b = now[t]
        if b == i:
            return True
        if b < 0:
            return False
        a = b
    return False


@njit(cache=True, nogil=True)
def _pibt(
    indptr: np.ndarray,
    indices: np.ndarray,
    pref: np.ndarray,
    goals: np.ndarray,
    q_from: np.ndarray,
    order: np.ndarray,
    fixed: np.ndarray,
    salt: int,
    occupied: np.ndarray,
) -> np.ndarray:
    """The next configuration from ``q_from`` (node per agent), agents planned in ``order`` with
    priority inheritance (iterative: an explicit stack instead of recursion) and swaps.
    ``fixed[i] >= 0`` fixes agent ``i``'s next node. An empty array when the fixed moves collide
    or an agent finds no node. ``occupied`` (``(2, n)``, -1 on entry and on exit) is scratch:
    who is at a node now, who will be next."""
    k = q_from.shape[0]
    now, nxt = occupied[0], occupied[1]
    q_to = fixed.copy()
    for i in range(k):
        now[q_from[i]] = i
    ok = True
    for i in range(k):  # the constraints: no two at one node, no swap
        u = q_to[i]
        if u >= 0:
            if nxt[u] >= 0:
                ok = False
                break
            nxt[u] = i
    for i in range(k):
        u = q_to[i]
        if ok and u >= 0 and u != q_from[i] and now[u] >= 0 and q_to[now[u]] == q_from[i]:
            ok = False
        moving = ok and u >= 0 and u != q_from[i] and now[u] >= 0 and now[u] != i
        if moving and _closes_cycle(i, now[u], q_from, q_to, now):
            ok = False  # fixed moves that rotate
    width = 1
    for v in q_from:
        width = max(width, indptr[v + 1] - indptr[v] + 1)
    cand = np.empty((k, width), dtype=np.int64)
    count = np.empty(k, dtype=np.int64)
    tried = np.empty(k, dtype=np.int64)
    partner = np.empty(k, dtype=np.int64)
    stack = np.empty(k, dtype=np.int64)
    for top in order:
        if not ok:
            break
        if q_to[top] >= 0:
            continue
        depth, result = 0, 0  # result of the agent last popped: 0 none, 1 moved, 2 failed
        push = top
        while True:
            if push >= 0:  # plan agent `push` next
                d = depth
                stack[d] = push
                count[d] = _candidates(indptr, indices, pref[push], q_from[push], salt, cand[d])
                partner[d] = _swap_partner(
                    indptr, indices, pref, goals, q_from, q_to, now, push, cand[d, 0]
                )
                if partner[d] >= 0:  # back off: the farthest node first
                    cand[d, : count[d]] = cand[d, : count[d]][::-1].copy()
                tried[d] = 0
                depth += 1
                push = -1
            if depth == 0:
                break
            d = depth - 1
            i = stack[d]
            if result != 1:
                result = 0
                while tried[d] < count[d]:
                    u = cand[d, tried[d]]
                    tried[d] += 1
                    if nxt[u] >= 0:
                        continue
                    j = now[u]
                    if j >= 0 and j != i and q_to[j] == q_from[i]:
                        continue  # a swap
                    if (
                        j >= 0
                        and j != i
                        and q_to[j] >= 0
                        and _closes_cycle(i, j, q_from, q_to, now)
                    ):
                        continue  # a rotation
                    nxt[u] = i
                    q_to[i] = u
                    if j < 0 or j == i or q_to[j] >= 0:
                        result = 1
                    else:
                        push = j  # priority inheritance: j must leave u
                    break
                if push >= 0:
                    continue
            depth -= 1
            if result == 1:
                s = partner[d]
                if (
                    s >= 0
                    and tried[d] == 1
                    and q_to[s] < 0
                    and nxt[q_from[i]] < 0
                    and not _closes_cycle(s, i, q_from, q_to, now)
                ):
                    nxt[q_from[i]] = s  # pull the partner into the node i leaves
                    q_to[s] = q_from[i]
            else:  # no node: stay, and let the agent that pushed try its next
                nxt[q_from[i]] = i
                q_to[i] = q_from[i]
                result = 2
        ok = result == 1
    for i in range(k):
        now[q_from[i]] = -1
        if q_to[i] >= 0:
            nxt[q_to[i]] = -1
    return q_to if ok else q_to[:0]


class Pibt:
    """PIBT on ``graph`` towards ``goals`` (node per agent), nearest first by ``preference``
    (``(k, n)``: agent ``i``'s cost from each node to its goal, e.g. ``cost_distances``), checked
    once here so that ``step``, called many times by a search, only converts."""

    def __init__(
        self, graph: Graph, goals: npt.NDArray[np.int64], preference: npt.NDArray[np.float64]
    ) -> None:
        pref = np.ascontiguousarray(preference, dtype=np.float64)
        if pref.ndim != 2 or pref.shape[1] != graph.nodes:
            msg = f"preference: a (k, {graph.nodes}) array expected, {pref.shape!r} given"
            raise ValueError(msg)
        self.indptr = np.ascontiguousarray(graph.indptr, dtype=np.int64)
        self.indices = np.ascontiguousarray(graph.indices, dtype=np.int64)
        self.preference = pref
        self.goals = np.ascontiguousarray(goals, dtype=np.int64)
        if self.goals.shape != (pref.shape[0],):
            msg = f"goals: {pref.shape[0]} expected, {self.goals.shape!r} given"
            raise ValueError(msg)
        self.agents = int(pref.shape[0])
        self.occupied = np.full((2, graph.nodes), -1, dtype=np.int64)

    def step(
        self,
        config: npt.NDArray[np.int64],
        order: npt.NDArray[np.int64],
        fixed: npt.NDArray[np.int64] | None = None,
        salt: int = 0,
    ) -> npt.NDArray[np.int64] | None:
        """The next configuration after ``config`` (node per agent), agents by ``order`` (first
        = highest priority), ``fixed[i] >= 0`` agent ``i``'s next node (a neighbour of its node
        or its node); None when no configuration meets the fixed moves. ``salt`` (0..2**62)
        seeds the tie-breaks."""
        if fixed is None:
            fixed = np.full(self.agents, -1, dtype=np.int64)
        out = _pibt(
            self.indptr, self.indices, self.preference, self.goals,
            config, order, fixed, salt, self.occupied,
        )  # fmt: skip
        return out if len(out) else None

"""Slow obvious references for MAPF (planner.fleets): a solution checker that knows nothing of
the solver, step distances by plain BFS (scipy's Dijkstra checks the costs), and PIBT as the
papers write it (recursive, with LaCAM3's swap), tie-breaks recomputed in plain integers."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from planner.fleets.graph import Graph

PRIME = 2**31 - 1


def check_solution(graph: Graph, starts: Any, goals: Any, paths: np.ndarray) -> tuple[int, int]:
    """``(sum_of_costs, makespan)`` of ``paths`` (``(T + 1, k)``), recomputed, after checking
    that it is a Moving AI MAPF solution: starts first, goals last, each step a move along an
    edge or a wait, never two agents at one node, never two swapping along an edge."""
    rows = [[int(v) for v in row] for row in paths]
    starts, goals = [int(v) for v in starts], [int(v) for v in goals]
    assert rows[0] == starts, f"row 0 {rows[0]} is not the starts {starts}"
    assert rows[-1] == goals, f"the last row {rows[-1]} is not the goals {goals}"
    edges = {(u, int(v)) for u in range(graph.nodes) for v in graph.neighbours(u)}
    for t in range(1, len(rows)):
        before, after = rows[t - 1], rows[t]
        assert len(set(after)) == len(after), f"two agents at one node at t={t}: {after}"
        for a, (u, v) in enumerate(zip(before, after, strict=True)):
            assert u == v or (u, v) in edges, f"agent {a} jumps {u} -> {v} at t={t}"
            for b, (x, y) in enumerate(zip(before, after, strict=True)):
                assert not (a != b and u != v and x == v and y == u), f"{a}, {b} swap at t={t}"
        _no_rotation(before, after, t)
    cost = 0
    for a, goal in enumerate(goals):
        away = [t for t, row in enumerate(rows) if row[a] != goal]
        cost += away[-1] + 1 if away else 0
    return cost, len(rows) - 1


def _no_rotation(before: list[int], after: list[int], t: int) -> None:
    """No agents moving into each other's nodes in a cycle at once (a fleet executes its plan by
    the order of its moves, and no order carries a rotation out)."""
    at = {v: a for a, v in enumerate(before)}
    follows = {a: at[v] for a, (u, v) in enumerate(zip(before, after, strict=True))
               if u != v and v in at}  # fmt: skip
    for start in follows:
        seen, a = set(), start
        while a in follows and a not in seen:
            seen.add(a)
            a = follows[a]
        assert a != start or start not in follows or a not in seen, f"a rotation at t={t}"


def bfs(graph: Graph, goal: int) -> list[int]:
    """Steps from every node to ``goal``, -1 where it cannot be reached."""
    out = [-1] * graph.nodes
    out[goal] = 0
    queue = deque([goal])
    while queue:
        u = queue.popleft()
        for v in graph.neighbours(u).tolist():
            if out[v] < 0:
                out[v] = out[u] + 1
                queue.append(v)
    return out


def tie_breaker(node: int, salt: int) -> int:
    x = (node * 48271 + salt) % PRIME
    x = (x * 16807 + (salt >> 31)) % PRIME
    return (x * 1103515245 + 12345) % PRIME


def pibt_step(
    graph: Graph,
    goals: list[int],
    pref: np.ndarray,
    q_from: list[int],
    order: list[int],
    fixed: list[int],
    salt: int,
) -> list[int] | None:
    """One PIBT configuration, or None when the fixed moves (``fixed[i] >= 0``) collide or an
    agent finds no node."""
    k = len(q_from)
    nbrs = [graph.neighbours(v).tolist() for v in range(graph.nodes)]
    now = {v: i for i, v in enumerate(q_from)}
    q_to: list[int | None] = [v if v >= 0 else None for v in fixed]
    nxt: dict[int, int] = {}
    for i in range(k):
        u = q_to[i]
        if u is not None:
            if u in nxt:
                return None
            nxt[u] = i

    def rotates(i: int, j: int) -> bool:
        """Whether ``i`` moving into ``j``'s node closes a cycle of agents moving at once."""
        a = j
        for _ in range(k):
            t = q_to[a]
            if t is None or t == q_from[a]:
                return False
            b = now.get(t)
            if b == i:
                return True
            if b is None:
                return False
            a = b
        return False

    for i in range(k):
        u = q_to[i]
        if u is not None and u != q_from[i] and u in now and q_to[now[u]] == q_from[i]:
            return None
        if u is not None and u != q_from[i] and now.get(u, i) != i and rotates(i, now[u]):
            return None

    def onward(behind: int, ahead: int) -> list[int]:
        return [
            u
            for u in nbrs[ahead]
            if u != behind and not (len(nbrs[u]) == 1 and u in now and goals[now[u]] == u)
        ]

    def required(pusher: int, puller: int, v_pusher: int, v_puller: int) -> bool:
        while pref[pusher][v_puller] < pref[pusher][v_pusher]:
            ways = onward(v_pusher, v_puller)
            if len(ways) >= 2:
                return False
            if not ways:
                break
            v_pusher, v_puller = v_puller, ways[-1]
        return bool(
            pref[puller][v_pusher] < pref[puller][v_puller]
            and (pref[pusher][v_pusher] == 0 or pref[pusher][v_puller] < pref[pusher][v_pusher])
        )

    def possible(v: int, w: int) -> bool:
        behind, ahead = v, w
        while ahead != v:
            ways = onward(behind, ahead)
            if len(ways) >= 2:
                return True
            if not ways:
                return False
            behind, ahead = ahead, ways[-1]
        return False

    def partner(i: int, best: int) -> int | None:
        v = q_from[i]
        j = now.get(best)
        if (
            j is not None
            and j != i
            and q_to[j] is None
            and required(i, j, v, best)
            and possible(best, v)
        ):
            return j
        if best != v:
            for u in nbrs[v]:
                a = now.get(u)
                if (
                    a is not None
                    and best != q_from[a]
                    and required(a, i, v, best)
                    and possible(best, v)
                ):
                    return a
        return None

    def plan(i: int) -> bool:
        v = q_from[i]
        cands = sorted([*nbrs[v], v], key=lambda u: (pref[i][u], tie_breaker(u, salt)))
        swap = partner(i, cands[0])
        if swap is not None:
            cands.reverse()
        for index, u in enumerate(cands):
            if u in nxt:
                continue
            j = now.get(u)
            if j is not None and j != i and q_to[j] == v:
                continue
            if j is not None and j != i and q_to[j] is not None and rotates(i, j):
                continue
            nxt[u], q_to[i] = i, u
            if j is not None and j != i and q_to[j] is None and not plan(j):
                continue
            if (
                swap is not None
                and index == 0
                and q_to[swap] is None
                and v not in nxt
                and not rotates(swap, i)
            ):
                nxt[v], q_to[swap] = swap, v
            return True
        nxt[v], q_to[i] = i, v
        return False

    for i in order:
        if q_to[i] is None and not plan(i):
            return None
    return [int(v) for v in q_to if v is not None]

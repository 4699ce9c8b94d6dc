"""Distance tables over a fleet's graph: for each agent's goal, every node's cost-to-go. MAPF
needs two: steps (BFS), the lower bound of a plan's sum of costs and LaCAM's heuristic, and edge
costs (Dijkstra), the preference by which PIBT orders an agent's next nodes."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput
from planner.fleets.graph import Graph

__all__ = ["UNREACHED", "cost_distances", "step_distances"]

UNREACHED = -1
"""A step distance where the goal cannot be reached (the cost distance there is ``inf``)."""


@njit(cache=True, nogil=True)
def _bfs(indptr: np.ndarray, indices: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """Steps from every node to each of ``goals`` (``(k, n)``, -1 where unreachable); edges are
    stored both ways, so the search runs out from the goal."""
    n = indptr.shape[0] - 1
    out = np.full((goals.shape[0], n), -1, dtype=np.int64)
    queue = np.empty(n, dtype=np.int64)
    for a in range(goals.shape[0]):
        row = out[a]
        row[goals[a]] = 0
        queue[0] = goals[a]
        head, tail = 0, 1
        while head < tail:
            u = queue[head]
            head += 1
            for e in range(indptr[u], indptr[u + 1]):
                v = indices[e]
                if row[v] < 0:
                    row[v] = row[u] + 1
                    queue[tail] = v
                    tail += 1
    return out


@njit(cache=True, nogil=True)
def _dijkstra(
    indptr: np.ndarray, indices: np.ndarray, costs: np.ndarray, goals: np.ndarray
) -> np.ndarray:
    """Edge-cost distances from every node to each of ``goals`` (``(k, n)``, inf where
    unreachable), with a binary heap of (distance, node) that keeps stale entries."""
    n = indptr.shape[0] - 1
    out = np.full((goals.shape[0], n), np.inf)
    size = indices.shape[0] + 1
    heap_d = np.empty(size)
    heap_v = np.empty(size, dtype=np.int64)
    for a in range(goals.shape[0]):
        row = out[a]
        row[goals[a]] = 0.0
        heap_d[0], heap_v[0] = 0.0, goals[a]
        length = 1
        while length > 0:
            d, u = heap_d[0], heap_v[0]
            length -= 1
            last_d, last_v = heap_d[length], heap_v[length]
            i = 0  # sift the last entry down from the root
            while True:
                c = 2 * i + 1
                if c >= length:
                    break
                if c + 1 < length and heap_d[c + 1] < heap_d[c]:
                    c += 1
                if heap_d[c] >= last_d:
                    break
                heap_d[i], heap_v[i] = heap_d[c], heap_v[c]
                i = c
            heap_d[i], heap_v[i] = last_d, last_v
            if d > row[u]:
                continue
            for e in range(indptr[u], indptr[u + 1]):
                v = indices[e]
                nd = d + costs[e]
                if nd < row[v]:
                    row[v] = nd
                    i = length  # sift the new entry up
                    length += 1
                    while i > 0 and heap_d[(i - 1) // 2] > nd:
                        heap_d[i], heap_v[i] = heap_d[(i - 1) // 2], heap_v[(i - 1) // 2]
                        i = (i - 1) // 2
                    heap_d[i], heap_v[i] = nd, v
    return out


def _goal_nodes(graph: Graph, goals: npt.ArrayLike) -> npt.NDArray[np.int64]:
    nodes = np.ascontiguousarray(goals, dtype=np.int64).reshape(-1)
    bad = np.nonzero((nodes < 0) | (nodes >= graph.nodes))[0]
    if len(bad):
        agent = int(bad[0])
        msg = f"goals: node {int(nodes[agent])} of agent {agent} is not in 0..{graph.nodes - 1}"
        raise InvalidInput(msg, field="goals")
    return nodes


def step_distances(graph: Graph, goals: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Steps (moves along edges) from every node to each goal: ``(k, n)`` int64, ``UNREACHED``
    where the goal cannot be reached.

    >>> from planner.fleets.graph import grid_graph
    >>> step_distances(grid_graph([[1, 1, 1], [0, 0, 1]]), [0]).tolist()
    [[0, 1, 2, 3]]
    """
    return np.asarray(_bfs(graph.indptr, graph.indices, _goal_nodes(graph, goals)))


def cost_distances(graph: Graph, goals: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Edge costs from every node to each goal: ``(k, n)`` float64, ``inf`` where the goal cannot
    be reached. When every edge costs the same this is the step distances times that cost.

    >>> from planner.fleets.graph import grid_graph
    >>> cost_distances(grid_graph([[1, 0], [1, 1]]), [2]).tolist()
    [[2.0, 1.0, 0.0]]
    """
    nodes = _goal_nodes(graph, goals)
    costs = graph.costs
    if len(costs) and bool(np.all(costs == costs[0])):
        steps = _bfs(graph.indptr, graph.indices, nodes)
        return np.where(steps >= 0, steps * float(costs[0]), np.inf)
    return np.asarray(_dijkstra(graph.indptr, graph.indices, costs, nodes))

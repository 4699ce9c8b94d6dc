"""Offline multi-agent path finding on a fleet's graph (docs/api.md, "The joint plan"): checked
starts and goals in, one timed node sequence per agent out, found by LaCAM with PIBT. Agents
move along edges or wait; never two at one node, never a swap along an edge; following (moving
into a node another agent leaves in the same step) is allowed, as in the Moving AI benchmark."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from planner.errors import InvalidInput, quote
from planner.fleets.distances import UNREACHED, cost_distances, step_distances
from planner.fleets.graph import Graph
from planner.fleets.lacam import Status, lacam
from planner.fleets.pibt import Pibt

__all__ = ["Solution", "solve"]


@dataclass(frozen=True, slots=True, eq=False)
class Solution:
    """A MAPF answer. ``paths`` (``(T + 1, k)`` int64) holds each agent's node at each timestep,
    row 0 the starts and row T the goals; ``(0, k)`` unless ``status`` is ``"solved"``.

    ``makespan`` is T; ``sum_of_costs`` sums, over the agents, the timestep after which each
    stays at its goal (the Moving AI benchmark's cost; both 0 unless solved). ``lower_bound``
    sums the agents' step distances start to goal (-1 when a goal cannot be reached at all).
    ``expanded`` counts the constraints tried (one PIBT call each), ``configurations`` the
    distinct configurations met.
    """

    status: Status
    paths: npt.NDArray[np.int64]
    makespan: int
    sum_of_costs: int
    lower_bound: int
    solve_ms: float
    expanded: int
    configurations: int

    @property
    def solved(self) -> bool:
        return self.status == "solved"


def solve(
    graph: Graph,
    starts: npt.ArrayLike,
    goals: npt.ArrayLike,
    *,
    time_limit_s: float = 10.0,
    seed: int = 0,
    blocked: npt.ArrayLike | None = None,
    refine: bool = False,
) -> Solution:
    """Paths for agents from ``starts`` to ``goals`` (node indices of ``graph``, one per agent)
    that never collide, found within ``time_limit_s`` seconds. ``blocked`` (a bool per node)
    marks nodes nobody may enter. ``refine`` keeps improving the sum of costs after the first
    solution until it is proven least or the time is up (LaCAM*); otherwise the first is kept.
    ``seed`` seeds PIBT's tie-breaks and the search's order.

    >>> from planner.fleets.graph import grid_graph
    >>> line = grid_graph([[1, 1, 1], [0, 1, 0]])  # nodes 0 1 2 on a row, 3 below 1
    >>> s = solve(line, [0, 2], [2, 0])
    >>> s.status, s.sum_of_costs, s.lower_bound
    ('solved', 7, 4)
    >>> solve(grid_graph([[1, 1]]), [0, 1], [1, 0]).status
    'unsolvable'
    """
    began = time.perf_counter()
    first = _nodes(graph, starts, "starts")
    last = _nodes(graph, goals, "goals")
    if len(first) != len(last):
        msg = f"goals: {len(last)} given for {len(first)} starts"
        raise InvalidInput(msg, field="goals")
    if not (isinstance(time_limit_s, int | float) and math.isfinite(time_limit_s)) or (
        time_limit_s <= 0
    ):
        msg = f"time_limit_s: a positive number of seconds expected, {quote(time_limit_s)} given"
        raise InvalidInput(msg, field="time_limit_s")
    if blocked is not None:
        graph = _without(graph, _blocked(graph, blocked, first, last))
    k = len(first)
    steps = step_distances(graph, last)
    to_go = steps[np.arange(k), first]
    if np.any(to_go == UNREACHED):
        return _unsolved("unsolvable", k, -1, began, 0, 0)
    lower_bound = int(to_go.sum())
    pibt = Pibt(graph, last, cost_distances(graph, last))
    neighbours = [graph.neighbours(v).tolist() for v in range(graph.nodes)]
    found = lacam(
        pibt, neighbours, first, last, steps,
        deadline=began + time_limit_s, seed=seed, refine=refine,
    )  # fmt: skip
    if found.status != "solved":
        return _unsolved(found.status, k, lower_bound, began, found.expanded, found.configurations)
    paths = np.stack(found.configs).astype(np.int64)
    away = paths != last
    # an agent's cost: one past the last timestep it is away from its goal
    costs = np.where(away.any(axis=0), len(paths) - np.argmax(away[::-1], axis=0), 0)
    return Solution(
        "solved", paths, len(paths) - 1, int(costs.sum()), lower_bound,
        (time.perf_counter() - began) * 1e3, found.expanded, found.configurations,
    )  # fmt: skip


def _unsolved(
    status: Status, k: int, lower_bound: int, began: float, expanded: int, configurations: int
) -> Solution:
    empty = np.zeros((0, k), dtype=np.int64)
    ms = (time.perf_counter() - began) * 1e3
    return Solution(status, empty, 0, 0, lower_bound, ms, expanded, configurations)


def _nodes(graph: Graph, value: npt.ArrayLike, field: str) -> npt.NDArray[np.int64]:
    """One node per agent, all in range and all different, or InvalidInput naming the agent."""
    array = np.asarray(value)
    if array.ndim != 1 or (array.size and array.dtype.kind not in "iu"):
        msg = f"{field}: a list of node indices expected, {quote(value)} given"
        raise InvalidInput(msg, field=field)
    nodes = array.astype(np.int64)
    for agent, node in enumerate(nodes.tolist()):
        if not 0 <= node < graph.nodes:
            msg = f"{field}: node {node} of agent {agent} is not in 0..{graph.nodes - 1}"
            raise InvalidInput(msg, field=field)
    values, counts = np.unique(nodes, return_counts=True)
    if np.any(counts > 1):
        node = int(values[np.argmax(counts > 1)])
        a, b = np.nonzero(nodes == node)[0][:2].tolist()
        msg = f"{field}: agents {a} and {b} share node {node}"
        raise InvalidInput(msg, field=field)
    return nodes


def _blocked(
    graph: Graph,
    blocked: npt.ArrayLike,
    starts: npt.NDArray[np.int64],
    goals: npt.NDArray[np.int64],
) -> npt.NDArray[np.bool_]:
    mask = np.asarray(blocked)
    if mask.dtype != np.bool_ or mask.shape != (graph.nodes,):
        msg = f"blocked: a bool per node ({graph.nodes},) expected, {quote(blocked)} given"
        raise InvalidInput(msg, field="blocked")
    for field, nodes in (("starts", starts), ("goals", goals)):
        on = np.nonzero(mask[nodes])[0]
        if len(on):
            msg = f"{field}: node {int(nodes[on[0]])} of agent {int(on[0])} is blocked"
            raise InvalidInput(msg, field=field)
    return mask


def _without(graph: Graph, blocked: npt.NDArray[np.bool_]) -> Graph:
    """``graph`` with the edges into and out of ``blocked`` nodes left out (nodes kept)."""
    source = np.repeat(np.arange(graph.nodes), np.diff(graph.indptr))
    keep = ~blocked[source] & ~blocked[graph.indices]
    indptr = np.zeros(graph.nodes + 1, dtype=np.int64)
    np.cumsum(np.bincount(source[keep], minlength=graph.nodes), out=indptr[1:])
    return Graph(
        graph.cells, indptr, graph.indices[keep].copy(), graph.costs[keep].copy(), graph.shape,
        radius=graph.radius, resolution=graph.resolution,
    )  # fmt: skip

"""The fleet roadmap (docs/fleets.md, "The roadmap"): a graph over a map's configuration space
whose nodes are at least ``2 * radius`` apart, and whose straight edges keep that distance from
every node but their ends and from every edge they share no node with, so that robots on
disjoint elements never touch. One-lane chains run along the middle of narrow passages; a
triangular lattice fills open floor.

>>> import planner
>>> m = planner.grid_map([[0] * 40] * 12, resolution=0.05)
>>> a = planner.analyse_map(m, planner.resolve_params("wide", robot_radius=0.1, unknown="free"))
>>> g = build_roadmap(a, radius=0.1)
>>> g.nodes, g.edges, attach(g, a, [0, 0])
(20, 37, 6)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.analysis.analyse import Analysis
from planner.analysis.cells import BLOCKED_CELL
from planner.errors import InvalidInput, quote
from planner.fleets.distances import cost_distances
from planner.fleets.graph import Graph, grid_graph
from planner.fleets.roadmap_nodes import roadmap_nodes, spacing
from planner.fleets.roadmap_repair import join_pieces
from planner.fleets.segments import point_segment_sq, segment_free, segment_segment_sq

__all__ = ["attach", "attach_all", "build_roadmap"]

#: Most edges a node keeps (a node's neighbours are ``2 * radius`` apart: a handful fit).
MAX_DEGREE = 16
#: Candidate edges reach this many lattice spacings (to join chains to the lattice).
REACH = 2.2
#: A start or goal joins a node within this many lattice spacings.
ATTACH_REACH = 2.0
# Squared distances must beat the separation by this much: float rounding never lets an edge
# in that exact arithmetic would find too close.
_SLACK = 1e-6


def build_roadmap(analysis: Analysis, *, radius: float, wide: bool = True) -> Graph:
    """The roadmap of ``analysis`` (the map's analysis for a robot of ``radius`` meters, so
    that its blocked cells are the configuration-space obstacles) for robots of at most
    ``radius`` meters. Nodes are cells the robot's center may occupy, at least ``2 * radius``
    apart; edges are straight moves whose every cell (supercover) is free, each at least
    ``2 * radius`` from every node but its ends and from every edge it shares no node with.

    Costs: the length in cells, plus with ``wide`` the ``clean`` penalty of each cell the move
    enters (its 8-connected line), as the single-robot ``wide`` preset pays it. When
    ``2 * radius`` is at most a cell, the roadmap is the free cells, 4-connected
    (:func:`~planner.fleets.graph.grid_graph`); when it is less than half a cell's diagonal
    (but not 0: a point robot moves as the Moving AI MAPF agents do), one diagonal of each
    free 2 x 2 block joins them too, the two directions in a checkerboard so that a diagonal
    run of either way has a lane of diagonals one cell aside.
    """
    if not isinstance(analysis, Analysis):
        msg = f"analysis: an Analysis expected; {type(analysis).__name__} given"
        raise TypeError(msg)
    r = _radius(radius)
    cs = analysis.cspace
    if cs is not None and cs.robot_radius < r:
        msg = (
            f"radius {r:g} m is more than the analysis's robot radius {cs.robot_radius:g} m: "
            "analyse the map for the fleet's largest robot"
        )
        raise InvalidInput(msg, field="radius")
    resolution = float(analysis.frame.resolution)
    free = np.ascontiguousarray(analysis.state != BLOCKED_CELL)
    clean = np.ascontiguousarray(analysis.clean, dtype=np.float64) if wide else None
    separation = 2.0 * r / resolution
    if separation <= 1.0:
        g = grid_graph(free, resolution=resolution)
        nodes, edges = g.cells, _pairs(g)
        if separation > 0.0 and separation * separation + _SLACK < 0.5:
            pairs = np.ascontiguousarray(np.concatenate([edges, _diagonals(free)]))
            keep = _accept(free, nodes, pairs, separation * separation + _SLACK, 1.5)
            edges = pairs[keep]
    else:
        nodes = roadmap_nodes(free, separation)
        edges = _edges(free, nodes, separation)
        reach = 2.0 * REACH * spacing(separation / 2.0)
        nodes, edges = join_pieces(free, nodes, edges, separation, reach)
    return _graph(nodes, edges, clean, free.shape, r, resolution)


def _radius(radius: Any) -> float:
    if isinstance(radius, bool) or not isinstance(radius, int | float):
        msg = f"radius must be a number of meters; got {quote(radius)}"
        raise InvalidInput(msg, field="radius")
    if not (math.isfinite(radius) and radius >= 0):
        msg = f"radius must be >= 0 meters; got {quote(radius)}"
        raise InvalidInput(msg, field="radius")
    return float(radius)


def _edges(
    free: npt.NDArray[np.bool_], nodes: npt.NDArray[np.int64], separation: float
) -> npt.NDArray[np.int64]:
    """The accepted edges ``(m, 2)``, candidates shortest first."""
    reach = REACH * spacing(separation / 2.0)
    pairs: npt.NDArray[np.int64] = _candidates(nodes, free.shape[0], free.shape[1], reach)
    d = nodes[pairs[:, 1]] - nodes[pairs[:, 0]]
    order = np.lexsort((pairs[:, 1], pairs[:, 0], (d * d).sum(axis=1)))
    pairs = np.ascontiguousarray(pairs[order])
    keep = _accept(free, nodes, pairs, separation * separation + _SLACK, reach)
    out: npt.NDArray[np.int64] = pairs[keep]
    return out


def _diagonals(free: npt.NDArray[np.bool_]) -> npt.NDArray[np.int64]:
    """One diagonal ``[a, b]`` (node numbers: free cells in row-major order) of each 2 x 2
    block of free cells: from its top left where its top left cell's row + column is even,
    else from its top right."""
    index = np.cumsum(free.ravel()).reshape(free.shape) - 1
    block = free[:-1, :-1] & free[:-1, 1:] & free[1:, :-1] & free[1:, 1:]
    rows, cols = np.nonzero(block)
    down = (rows + cols) % 2 == 0
    a = np.where(down, index[rows, cols], index[rows, cols + 1])
    b = np.where(down, index[rows + 1, cols + 1], index[rows + 1, cols])
    return np.stack([a, b], axis=1).astype(np.int64)


def _pairs(g: Graph) -> npt.NDArray[np.int64]:
    source = np.repeat(np.arange(g.nodes), np.diff(g.indptr))
    keep = source < g.indices
    return np.stack([source[keep], g.indices[keep]], axis=1).astype(np.int64)


def _graph(
    nodes: npt.NDArray[np.int64],
    edges: npt.NDArray[np.int64],
    clean: npt.NDArray[np.float64] | None,
    shape: tuple[int, int],
    radius: float,
    resolution: float,
) -> Graph:
    """The CSR graph of undirected ``edges``, each stored both ways with its own cost."""
    source = np.concatenate([edges[:, 0], edges[:, 1]])
    target = np.concatenate([edges[:, 1], edges[:, 0]])
    order = np.lexsort((target, source))
    source, target = source[order], target[order]
    d = (nodes[target] - nodes[source]).astype(np.float64)
    costs = np.hypot(d[:, 0], d[:, 1])
    if clean is not None:
        costs += _penalties(
            clean, nodes, np.ascontiguousarray(source), np.ascontiguousarray(target)
        )
    indptr = np.zeros(len(nodes) + 1, dtype=np.int64)
    np.cumsum(np.bincount(source, minlength=len(nodes)), out=indptr[1:])
    return Graph(
        np.ascontiguousarray(nodes, dtype=np.int64), indptr, target.astype(np.int64), costs,
        (int(shape[0]), int(shape[1])), radius=radius, resolution=resolution,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def _penalties(
    clean: npt.NDArray[np.float64],
    nodes: npt.NDArray[np.int64],
    source: npt.NDArray[np.int64],
    target: npt.NDArray[np.int64],
) -> npt.NDArray[np.float64]:
    """For each move, the ``clean`` of the cells its 8-connected line enters (the start's
    excluded, the end's included)."""
    out = np.zeros(source.size, dtype=np.float64)
    for e in range(source.size):
        r0, c0 = nodes[source[e], 0], nodes[source[e], 1]
        dr, dc = nodes[target[e], 0] - r0, nodes[target[e], 1] - c0
        n = max(abs(dr), abs(dc))
        total = 0.0
        for k in range(1, n + 1):
            total += clean[r0 + round(dr * k / n), c0 + round(dc * k / n)]
        out[e] = total
    return out


@njit(cache=True, nogil=True)
def _buckets(
    nodes: npt.NDArray[np.int64], size: float, H: int, W: int
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], int, int]:
    """Nodes in square buckets of ``size`` cells: ``head[bucket]`` its first node, ``after``
    the next node of the same bucket (-1 ends), and the buckets' grid shape."""
    bh, bw = int(H / size) + 1, int(W / size) + 1
    head = np.full(bh * bw, -1, dtype=np.int64)
    after = np.full(nodes.shape[0], -1, dtype=np.int64)
    for k in range(nodes.shape[0]):
        b = int(nodes[k, 0] / size) * bw + int(nodes[k, 1] / size)
        after[k] = head[b]
        head[b] = k
    return head, after, bh, bw


@njit(cache=True, nogil=True)
def _candidates(
    nodes: npt.NDArray[np.int64], H: int, W: int, reach: float
) -> npt.NDArray[np.int64]:  # fmt: skip
    """Every pair ``[a, b]`` (``a < b``) of nodes at most ``reach`` apart."""
    head, after, bh, bw = _buckets(nodes, reach, H, W)
    count = 0
    for phase in range(2):
        if phase == 1:
            out = np.empty((count, 2), dtype=np.int64)
            count = 0
        for a in range(nodes.shape[0]):
            br, bc = int(nodes[a, 0] / reach), int(nodes[a, 1] / reach)
            for i in range(max(0, br - 1), min(bh, br + 2)):
                for j in range(max(0, bc - 1), min(bw, bc + 2)):
                    b = head[i * bw + j]
                    while b >= 0:
                        dr, dc = nodes[b, 0] - nodes[a, 0], nodes[b, 1] - nodes[a, 1]
                        if b > a and dr * dr + dc * dc <= reach * reach:
                            if phase == 1:
                                out[count, 0], out[count, 1] = a, b
                            count += 1
                        b = after[b]
    return out


@njit(cache=True, nogil=True)
def _accept(
    free: npt.NDArray[np.bool_],
    nodes: npt.NDArray[np.int64],
    pairs: npt.NDArray[np.int64],
    limit_sq: float,
    reach: float,
) -> npt.NDArray[np.bool_]:
    """Greedily, in the order of ``pairs``: keep an edge whose cells are free, that no node but
    its ends comes within the separation of, nor any kept edge sharing no node with it
    (squared distances below ``limit_sq``). An edge in conflict with a kept one has an end
    within ``reach + separation + reach / 2`` of its midpoint: two buckets of ``reach``."""
    H, W = free.shape
    head, after, bh, bw = _buckets(nodes, reach, H, W)
    degree = np.zeros(nodes.shape[0], dtype=np.int64)
    adjacent = np.empty((nodes.shape[0], MAX_DEGREE), dtype=np.int64)
    keep = np.zeros(pairs.shape[0], dtype=np.bool_)
    for e in range(pairs.shape[0]):
        a, b = pairs[e, 0], pairs[e, 1]
        if degree[a] == MAX_DEGREE or degree[b] == MAX_DEGREE:
            continue
        ar, ac, br_, bc_ = nodes[a, 0], nodes[a, 1], nodes[b, 0], nodes[b, 1]
        if not segment_free(free, ar, ac, br_, bc_):
            continue
        ok = True
        mr, mc = int((ar + br_) / 2 / reach), int((ac + bc_) / 2 / reach)
        for i in range(max(0, mr - 2), min(bh, mr + 3)):
            for j in range(max(0, mc - 2), min(bw, mc + 3)):
                k = head[i * bw + j]
                while k >= 0 and ok:
                    if k != a and k != b:
                        kr, kc = nodes[k, 0], nodes[k, 1]
                        if point_segment_sq(kr, kc, ar, ac, br_, bc_) < limit_sq:
                            ok = False
                        for t in range(degree[k]):
                            m = adjacent[k, t]
                            if ok and m != a and m != b:
                                d = segment_segment_sq(
                                    ar, ac, br_, bc_, kr, kc, nodes[m, 0], nodes[m, 1]
                                )
                                if d < limit_sq:
                                    ok = False
                    k = after[k]
        if ok:
            keep[e] = True
            adjacent[a, degree[a]] = b
            adjacent[b, degree[b]] = a
            degree[a] += 1
            degree[b] += 1
    return keep


def attach(
    graph: Graph, analysis: Analysis, cell: Any, *, exclude: Any = (), toward: int = -1
) -> int:
    """The node a robot at ``cell`` (``[row, col]``) joins, by a straight move whose every
    cell is free, within two lattice spacings, and not one of ``exclude`` (nodes other robots
    join): the nearest; or, heading for node ``toward``, the one whose move there plus the
    roadmap's shortest route on to ``toward`` is least (no joining behind and coming back past
    the start), the nearest when none leads there. -1 if none."""
    return int(attach_all(graph, analysis, [cell], exclude=exclude, toward=[toward])[0])


def attach_all(
    graph: Graph, analysis: Analysis, cells: Any, *, exclude: Any = (), toward: Any = None
) -> npt.NDArray[np.int64]:
    """:func:`attach` for each of ``cells`` (``(k, 2)``), heading for ``toward`` (``k``
    nodes, -1 for the nearest; None: the nearest for all)."""
    if analysis.shape != graph.shape:
        msg = f"analysis of shape {analysis.shape!r} for a graph of shape {graph.shape!r}"
        raise InvalidInput(msg, field="analysis")
    query = np.asarray(cells)
    if query.ndim != 2 or query.shape[1] != 2 or not np.issubdtype(query.dtype, np.integer):
        msg = f"cells: a (k, 2) array of [row, col] integers expected; {quote(cells)} given"
        raise InvalidInput(msg, field="cells")
    heading = np.full(len(query), -1, dtype=np.int64) if toward is None else np.asarray(toward)
    if heading.shape != (len(query),) or not np.issubdtype(heading.dtype, np.integer):
        msg = f"toward: one node (or -1) per cell expected; {quote(toward)} given"
        raise InvalidInput(msg, field="toward")
    if len(heading) and not (heading.min() >= -1 and heading.max() < graph.nodes):
        msg = f"toward: nodes in 0..{graph.nodes - 1} (or -1) expected; {quote(toward)} given"
        raise InvalidInput(msg, field="toward")
    # Row 0 costs nothing (the nearest node); row i + 1 is the cost to the i-th node headed for.
    targets, row = np.unique(heading[heading >= 0], return_inverse=True)
    togo = np.zeros((1 + len(targets), graph.nodes))
    togo[1:] = cost_distances(_by_length(graph), targets)
    rows = np.zeros(len(heading), dtype=np.int64)
    rows[heading >= 0] = row + 1
    free = np.ascontiguousarray(analysis.state != BLOCKED_CELL)
    reach = ATTACH_REACH * spacing(graph.radius / graph.resolution)
    taken = np.zeros(graph.nodes, dtype=np.bool_)
    taken[np.asarray(list(exclude), dtype=np.int64)] = True
    out: npt.NDArray[np.int64] = _attach(
        free, np.ascontiguousarray(graph.cells), query.astype(np.int64), reach * reach, taken,
        togo, rows,
    )  # fmt: skip
    return out


def _by_length(graph: Graph) -> Graph:
    """``graph`` with each edge's length for its cost: a route's length, like a move's."""
    source = np.repeat(np.arange(graph.nodes), np.diff(graph.indptr))
    d = (graph.cells[graph.indices] - graph.cells[source]).astype(np.float64)
    return Graph(
        graph.cells, graph.indptr, graph.indices, np.hypot(d[:, 0], d[:, 1]), graph.shape,
        radius=graph.radius, resolution=graph.resolution,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def _attach(
    free: npt.NDArray[np.bool_],
    nodes: npt.NDArray[np.int64],
    query: npt.NDArray[np.int64],
    reach_sq: float,
    taken: npt.NDArray[np.bool_],
    togo: npt.NDArray[np.float64],
    rows: npt.NDArray[np.int64],
) -> npt.NDArray[np.int64]:
    """For each query cell, of the nodes in reach, in sight and not taken, the one of least
    straight distance plus ``togo[rows[q]]`` (finite first), the nearest on ties; -1 if
    none. Nodes are tried nearest first, and the search stops where the distance alone
    exceeds the best found (``togo`` is never negative)."""
    out = np.full(query.shape[0], -1, dtype=np.int64)
    for q in range(query.shape[0]):
        r, c = query[q, 0], query[q, 1]
        d = (nodes[:, 0] - r) ** 2 + (nodes[:, 1] - c) ** 2
        order = np.argsort(d, kind="mergesort")
        best, nearest = np.inf, -1
        for k in order:
            if d[k] > reach_sq or math.sqrt(d[k]) >= best:
                break
            if taken[k] or not segment_free(free, r, c, nodes[k, 0], nodes[k, 1]):
                continue
            if nearest < 0:
                nearest = k
            score = math.sqrt(d[k]) + togo[rows[q], k]
            if score < best - 1e-9:  # a nearer node keeps a tie (up to rounding)
                best, out[q] = score, k
        if out[q] < 0:
            out[q] = nearest
    return out

"""Slow, obvious references for the fleet roadmap: the supercover of a segment by exact
rational arithmetic, every pair of disjoint roadmap elements closer than the separation (by
integer geometry), routes through the roadmap by Dijkstra, and the node a cell joins."""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components, dijkstra

from planner.fleets.graph import Graph


def supercover(a: tuple[int, int], b: tuple[int, int]) -> set[tuple[int, int]]:
    """The cells whose closed squares meet the segment between the centers of ``a`` and ``b``:
    each cell of the bounding box clipped against the segment (Liang-Barsky, in fractions)."""
    (r0, c0), (r1, c1) = a, b
    out = set()
    for r in range(min(r0, r1), max(r0, r1) + 1):
        for c in range(min(c0, c1), max(c0, c1) + 1):
            lo, hi = Fraction(0), Fraction(1)
            ok = True
            for start, delta, low, high in (
                (r0, r1 - r0, r - Fraction(1, 2), r + Fraction(1, 2)),
                (c0, c1 - c0, c - Fraction(1, 2), c + Fraction(1, 2)),
            ):
                if delta == 0:
                    ok = ok and low <= start <= high
                    continue
                t0, t1 = (low - start) / delta, (high - start) / delta
                lo, hi = max(lo, min(t0, t1)), min(hi, max(t0, t1))
            if ok and lo <= hi:
                out.add((r, c))
    return out


def elements(graph: Graph) -> npt.NDArray[np.int64]:
    """Every node as ``[u, u]`` and every edge as ``[u, v]`` (``u < v``)."""
    nodes = np.arange(graph.nodes)
    source = np.repeat(nodes, np.diff(graph.indptr))
    keep = source < graph.indices
    return np.concatenate(
        [np.stack([nodes, nodes], axis=1), np.stack([source[keep], graph.indices[keep]], axis=1)]
    ).astype(np.int64)


def _point_segment_sq(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared distances from points to segments, integer coordinates: exact but for the last
    division."""
    ab, ap = b - a, p - a
    length = (ab * ab).sum(axis=1)
    dot = (ap * ab).sum(axis=1)
    cross = ab[:, 0] * ap[:, 1] - ab[:, 1] * ap[:, 0]
    to_a = (ap * ap).sum(axis=1)
    bp = p - b
    to_b = (bp * bp).sum(axis=1)
    inner = cross.astype(np.float64) ** 2 / np.maximum(length, 1)
    out: np.ndarray = np.where(dot <= 0, to_a, np.where(dot >= length, to_b, inner))
    return np.asarray(out, dtype=np.float64)


def _orient(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    turn = (b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[:, 0] - a[:, 0])
    out: np.ndarray = np.sign(turn)
    return out


def segment_sq(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Squared distances between segments ``ab`` and ``cd`` (rows; points are segments of one
    point): 0 where they cross, else the least endpoint-to-segment distance."""
    o1, o2 = _orient(a, b, c), _orient(a, b, d)
    o3, o4 = _orient(c, d, a), _orient(c, d, b)
    cross = (o1 * o2 < 0) & (o3 * o4 < 0)
    least = np.minimum.reduce(
        [
            _point_segment_sq(c, a, b),
            _point_segment_sq(d, a, b),
            _point_segment_sq(a, c, d),
            _point_segment_sq(b, c, d),
        ]
    )
    return np.where(cross, 0.0, least)


def too_close(graph: Graph, separation: float) -> list[tuple[int, int, int, int, float]]:
    """Every pair of roadmap elements sharing no node that comes nearer than ``separation``
    cells: ``(u1, v1, u2, v2, distance)``. All pairs whose elements' first ends are within two
    longest edges and the separation of each other (the only ones that can be that close) are
    measured: a grid of buckets of that size, each against its 3 x 3 neighbourhood."""
    items = elements(graph)
    cells = graph.cells
    ends = cells[items]  # (m, 2, 2)
    lengths = np.sqrt(((ends[:, 1] - ends[:, 0]) ** 2).sum(axis=1))
    size = float(lengths.max(initial=0.0)) + separation + 1.0
    bucket = ((ends[:, 0] + ends[:, 1]) / 2 // size).astype(np.int64)
    groups: dict[tuple[int, int], list[int]] = {}
    for k, (i, j) in enumerate(bucket.tolist()):
        groups.setdefault((i, j), []).append(k)
    found: list[tuple[int, int, int, int, float]] = []
    limit = separation * separation
    for (i, j), members in groups.items():
        mine = np.array(members)
        for di, dj in itertools.product((-1, 0, 1), repeat=2):
            theirs = groups.get((i + di, j + dj))
            if theirs is None:
                continue
            x, y = np.meshgrid(mine, np.array(theirs), indexing="ij")
            x, y = x.ravel(), y.ravel()
            keep = x < y
            x, y = x[keep], y[keep]
            a, b = items[x], items[y]
            disjoint = (a[:, 0] != b[:, 0]) & (a[:, 0] != b[:, 1])
            disjoint &= (a[:, 1] != b[:, 0]) & (a[:, 1] != b[:, 1])
            x, y = x[disjoint], y[disjoint]
            d = segment_sq(ends[x, 0], ends[x, 1], ends[y, 0], ends[y, 1])
            bad = d < limit - 1e-9
            for p, q, dd in zip(x[bad].tolist(), y[bad].tolist(), d[bad].tolist(), strict=True):
                found.append((*items[p].tolist(), *items[q].tolist(), float(np.sqrt(dd))))
    return found


def lengths_matrix(graph: Graph) -> csr_matrix:
    """The graph's edges weighted by their length in cells."""
    source = np.repeat(np.arange(graph.nodes), np.diff(graph.indptr))
    d = graph.cells[graph.indices] - graph.cells[source]
    weight = np.hypot(d[:, 0], d[:, 1])
    return csr_matrix((weight, graph.indices, graph.indptr), shape=(graph.nodes, graph.nodes))


def components(graph: Graph) -> npt.NDArray[np.int64]:
    """The connected component of each node."""
    labels: npt.NDArray[np.int64] = connected_components(lengths_matrix(graph), directed=False)[1]
    return labels


def route_lengths(
    graph: Graph, starts: np.ndarray, goals: np.ndarray, s_nodes: np.ndarray, g_nodes: np.ndarray
) -> npt.NDArray[np.float64]:
    """The shortest route's length in cells from each start through its node, the roadmap and
    the goal's node to the goal (inf when not connected)."""
    matrix = lengths_matrix(graph)
    unique, back = np.unique(s_nodes, return_inverse=True)
    table = dijkstra(matrix, directed=False, indices=unique)
    out = np.empty(len(starts))
    for k in range(len(starts)):
        inner = table[back[k], g_nodes[k]]
        out[k] = (
            np.hypot(*(graph.cells[s_nodes[k]] - starts[k]))
            + inner
            + np.hypot(*(graph.cells[g_nodes[k]] - goals[k]))
        )
    return out


def attach(graph: Graph, free: np.ndarray, cell: tuple[int, int], reach: float, toward: int) -> int:
    """The node ``cell`` joins: of the nodes within ``reach`` cells whose straight move from
    ``cell`` is free (every cell of its exact supercover), the one of least move length plus
    the shortest route's length on to ``toward`` (-1: plus nothing), the nearer on ties; the
    nearest such node when none leads to ``toward``; -1 when there is none."""
    d = np.hypot(*(graph.cells - np.array(cell)).T)
    togo = (
        np.zeros(graph.nodes)
        if toward < 0
        else dijkstra(lengths_matrix(graph), directed=False, indices=toward)
    )
    seen = [
        k
        for k in np.argsort(d, kind="stable").tolist()
        if d[k] <= reach and all(free[c] for c in supercover(cell, tuple(graph.cells[k].tolist())))
    ]
    if not seen:
        return -1
    least = min(d[k] + togo[k] for k in seen)
    if not np.isfinite(least):
        return int(seen[0])
    return int(next(k for k in seen if d[k] + togo[k] <= least + 1e-9))  # ties: the nearest

"""Joining the roadmap's pieces (docs/fleets.md, "The roadmap"): where the greedy edges left a
chain or a patch of lattice cut off from the rest though the free space joins them (a corridor's
mouth whose lattice nodes crowd the chain's end), a longer straight edge joins them, the few
nodes and edges in its way taken out, so long as the pieces are then fewer."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from planner.fleets.execution import segment_distances
from planner.fleets.graph import pieces as graph_pieces
from planner.fleets.segments import segment_free

__all__ = ["join_pieces"]

TRIES = 64
"""Candidate edges tried per piece, shortest first."""


def join_pieces(
    free: npt.NDArray[np.bool_],
    nodes: npt.NDArray[np.int64],
    edges: npt.NDArray[np.int64],
    separation: float,
    reach: float,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """``nodes`` and ``edges`` with the roadmap's pieces joined where a straight free edge of
    at most ``reach`` cells can join two, keeping every element ``separation`` from every
    disjoint one: the nodes and edges in the way are removed. Gives up on a piece when no edge
    makes the pieces fewer."""
    limit = separation * separation + 1e-6
    hopeless: set[tuple[int, int]] = set()  # pieces (by a node's cell) that no edge joins
    for _ in range(len(nodes)):
        pieces, labels = _pieces(len(nodes), edges)
        if pieces <= 1:
            break
        joined = False
        sizes = np.bincount(labels)
        for piece in np.argsort(sizes, kind="stable"):  # the smallest pieces first
            first = int(np.argmax(labels == piece))
            key = (int(nodes[first, 0]), int(nodes[first, 1]))
            if key in hopeless:
                continue
            found = _join(free, nodes, edges, labels, int(piece), limit, reach, pieces)
            if found is not None:
                nodes, edges = found
                joined = True
                break
            hopeless.add(key)
        if not joined:
            break
    return nodes, edges


def _pieces(count: int, edges: npt.NDArray[np.int64]) -> tuple[int, npt.NDArray[np.int64]]:
    return graph_pieces(count, edges[:, 0], edges[:, 1])


def _join(
    free: npt.NDArray[np.bool_],
    nodes: npt.NDArray[np.int64],
    edges: npt.NDArray[np.int64],
    labels: npt.NDArray[np.int64],
    piece: int,
    limit: float,
    reach: float,
    pieces: int,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]] | None:
    """The roadmap with ``piece`` joined to another by one edge, or None."""
    inside = np.nonzero(labels == piece)[0]
    points = nodes.astype(np.float64)
    tree = cKDTree(points)
    pairs: list[tuple[float, int, int]] = []
    for a, found in zip(inside.tolist(), tree.query_ball_point(points[inside], reach), strict=True):
        for b in found:
            if labels[b] != piece:
                pairs.append((float(np.hypot(*(points[b] - points[a]))), a, int(b)))
    lengths = np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1)
    longest = float(lengths.max()) if len(lengths) else reach
    for _, a, b in sorted(pairs)[:TRIES]:
        (ar, ac), (br, bc) = nodes[a], nodes[b]
        if not segment_free(free, ar, ac, br, bc):
            continue
        p, q = points[a], points[b]
        # Only elements near the segment can be in its way.
        around = tree.query_ball_point((p + q) / 2, np.hypot(*(q - p)) / 2 + reach + longest)
        local = np.zeros(len(nodes), dtype=bool)
        local[np.asarray(around, dtype=np.int64)] = True
        near = np.zeros(len(nodes), dtype=bool)
        near[local] = segment_distances(p, q, points[local], points[local]) ** 2 < limit
        near[[a, b]] = False
        ends = edges[:, 0], edges[:, 1]
        close = np.zeros(len(edges), dtype=bool)
        mine = local[ends[0]] | local[ends[1]]
        close[mine] = (
            segment_distances(p, q, points[ends[0][mine]], points[ends[1][mine]]) ** 2 < limit
        )
        close &= (ends[0] != a) & (ends[0] != b) & (ends[1] != a) & (ends[1] != b)
        gone = near.copy()
        keep = ~close & ~gone[ends[0]] & ~gone[ends[1]]
        survivors = np.nonzero(~gone)[0]
        renumber = np.full(len(nodes), -1, dtype=np.int64)
        renumber[survivors] = np.arange(len(survivors))
        new_edges = np.concatenate([edges[keep], [[a, b]]])
        new_edges = renumber[new_edges]
        new_nodes = nodes[survivors]
        after, _ = _pieces(len(new_nodes), new_edges)
        if after < pieces:
            return new_nodes, np.ascontiguousarray(new_edges)
    return None

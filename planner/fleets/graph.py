"""The graph a fleet moves on (docs/fleets.md): nodes at cells, straight edges between them, in
compressed sparse rows so that kernels read it without Python objects. The roadmap builder makes
one for a robot map; a plain grid with radius 0 is its free cells, 4-connected."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

__all__ = ["Graph", "grid_graph", "pieces"]


@dataclass(frozen=True, slots=True, eq=False)
class Graph:
    """Nodes at ``cells`` (``(n, 2)`` row, col) with edges ``indptr``/``indices`` (CSR: node
    ``u``'s neighbours are ``indices[indptr[u]:indptr[u + 1]]``, each edge stored both ways) and
    ``costs`` (one per stored edge, what the preset makes of it; at least its length in cells).

    ``radius`` (meters) is the robot radius the graph separates: two robots of at most that
    radius on different nodes, or moving along edges that share no node, never overlap.
    ``shape`` is the map's ``(height, width)``, ``resolution`` its meters per cell.
    """

    cells: npt.NDArray[np.int64]
    indptr: npt.NDArray[np.int64]
    indices: npt.NDArray[np.int64]
    costs: npt.NDArray[np.float64]
    shape: tuple[int, int]
    radius: float = 0.0
    resolution: float = 1.0

    def __post_init__(self) -> None:
        for array in (self.cells, self.indptr, self.indices, self.costs):
            array.flags.writeable = False

    @property
    def nodes(self) -> int:
        return int(self.cells.shape[0])

    @property
    def edges(self) -> int:
        """Undirected edges."""
        return int(self.indices.shape[0]) // 2

    def neighbours(self, node: int) -> npt.NDArray[np.int64]:
        return self.indices[self.indptr[node] : self.indptr[node + 1]]

    def pieces(self) -> npt.NDArray[np.int64]:
        """The connected piece of each node (robots move within one): :func:`pieces`' labels."""
        source = np.repeat(np.arange(self.nodes), np.diff(self.indptr))
        return pieces(self.nodes, source, self.indices)[1]

    def node_of(self, cells: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """The node at each of ``cells`` (``(k, 2)``), -1 where none is."""
        query = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
        width = self.shape[1]
        keys = self.cells[:, 0] * width + self.cells[:, 1]
        order = np.argsort(keys, kind="stable")
        wanted = query[:, 0] * width + query[:, 1]
        at = np.searchsorted(keys, wanted, sorter=order)
        at = np.minimum(at, max(len(keys) - 1, 0))
        found = order[at] if len(keys) else np.zeros(len(wanted), dtype=np.int64)
        hit = len(keys) > 0 and (keys[found] == wanted)
        return np.where(hit, found, -1).astype(np.int64)


def pieces(
    nodes: int, source: npt.ArrayLike, target: npt.ArrayLike
) -> tuple[int, npt.NDArray[np.int64]]:
    """How many connected pieces ``nodes`` nodes joined by the edges ``source[i]``-``target[i]``
    make, and the piece of each node (scipy's labels).

    >>> pieces(4, [0, 2], [1, 3])[0]
    2
    """
    ends = np.asarray(source, dtype=np.int64), np.asarray(target, dtype=np.int64)
    matrix = coo_matrix((np.ones(len(ends[0])), ends), shape=(nodes, nodes))
    count, labels = connected_components(matrix, directed=False)
    return int(count), labels.astype(np.int64)


def grid_graph(free: npt.ArrayLike, *, resolution: float = 1.0) -> Graph:
    """The free cells of ``free`` (``(H, W)``, truthy = free), 4-connected, each edge of cost 1:
    the graph of the Moving AI MAPF benchmark.

    >>> g = grid_graph([[1, 1], [0, 1]])
    >>> g.cells.tolist(), g.neighbours(1).tolist(), g.edges
    ([[0, 0], [0, 1], [1, 1]], [0, 2], 2)
    """
    grid = np.asarray(free).astype(bool)
    if grid.ndim != 2:
        msg = f"free: a 2D grid expected, an array of shape {grid.shape!r} given"
        raise ValueError(msg)
    height, width = grid.shape
    index = np.full(grid.shape, -1, dtype=np.int64)
    rows, cols = np.nonzero(grid)
    index[rows, cols] = np.arange(len(rows))
    sources, targets = [], []
    for dr, dc in ((-1, 0), (0, -1), (0, 1), (1, 0)):  # neighbours in index order
        r2, c2 = rows + dr, cols + dc
        inside = (r2 >= 0) & (r2 < height) & (c2 >= 0) & (c2 < width)
        other = np.full(len(rows), -1, dtype=np.int64)
        other[inside] = index[r2[inside], c2[inside]]
        keep = other >= 0
        sources.append(np.nonzero(keep)[0])
        targets.append(other[keep])
    source = np.concatenate(sources) if sources else np.zeros(0, dtype=np.int64)
    target = np.concatenate(targets) if targets else np.zeros(0, dtype=np.int64)
    order = np.lexsort((target, source))
    source, target = source[order], target[order]
    indptr = np.zeros(len(rows) + 1, dtype=np.int64)
    np.cumsum(np.bincount(source, minlength=len(rows)), out=indptr[1:])
    cells = np.stack([rows, cols], axis=1).astype(np.int64)
    return Graph(
        cells, indptr, target.astype(np.int64), np.ones(len(target)), (height, width),
        radius=0.0, resolution=resolution,
    )  # fmt: skip

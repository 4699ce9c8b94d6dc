"""Where the fleet roadmap's nodes go (docs/fleets.md, "The roadmap"): chains along the medial
axis where free space is narrow (its junctions first, widest first, then along each chain),
then a triangular lattice over open floor, then the widest cell of any piece of free space
still without a node; a cell is taken only when no node is nearer than the separation.

>>> import numpy as np
>>> free = np.zeros((9, 60), dtype=bool)
>>> free[4, :] = True   # a corridor one cell wide: one chain (its ends pruned as spurs are)
>>> roadmap_nodes(free, 10.0)[:, 1].tolist()
[14, 25, 36]
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit
from scipy import ndimage

from planner.analysis.distance import squared_distances
from planner.analysis.medial import medial_axis
from planner.fleets.segments import segment_free

__all__ = ["SNAP_MARGIN", "roadmap_nodes", "spacing"]

#: Cells added to the separation for nodes snapped to cell centers.
SNAP_MARGIN = 1.5


def spacing(radius_cells: float) -> float:
    """The triangular lattice's spacing for a separation of ``2 * radius_cells`` cells: its
    rows are the separation plus a snapping margin apart (``sqrt(3) / 2`` of the spacing)."""
    return 2.0 * (2.0 * radius_cells + SNAP_MARGIN) / math.sqrt(3.0)


def roadmap_nodes(free: npt.NDArray[np.bool_], separation: float) -> npt.NDArray[np.int64]:
    """The roadmap's nodes ``(n, 2)`` ``[row, col]`` over the ``free`` cells (``(H, W)``
    booleans: where a robot's center may be), more than ``separation`` cells apart (the
    fleet's diameter in cells, > 1)."""
    grid = np.asarray(free)
    if grid.ndim != 2 or grid.dtype != np.bool_:
        msg = f"free: a 2-D boolean array expected; {grid.dtype} of shape {grid.shape!r} given"
        raise TypeError(msg)
    if not (math.isfinite(separation) and separation > 1.0):
        msg = f"separation: more than one cell expected; {separation!r} given"
        raise ValueError(msg)
    return _nodes(np.ascontiguousarray(grid), float(separation))


def _nodes(free: npt.NDArray[np.bool_], separation: float) -> npt.NDArray[np.int64]:
    """Chain nodes along the medial axis where the free space is narrower than two lattice
    spacings, then lattice nodes, each kept only if no node is nearer than the separation."""
    clear = np.sqrt(squared_distances(free, outside_blocked=True))
    step = spacing(separation / 2.0)
    trunk = _prune(np.ascontiguousarray(medial_axis(free, clear)), math.ceil(step))
    skeleton = trunk & (clear < step)
    minimum = separation + 0.5  # nodes snapped to cells: half a cell more
    bends = _bends(free, np.ascontiguousarray(skeleton), math.ceil(minimum / 2.0))
    order = _chain_order(np.ascontiguousarray(skeleton), clear, bends)
    # A piece of free space too small for chain or lattice still gets its widest cell (pieces
    # 4-connected: a robot crosses no zero-width diagonal gap).
    labels, pieces = ndimage.label(free)
    widest = ndimage.maximum_position(clear, labels, np.arange(1, pieces + 1))
    fill = np.array([r * free.shape[1] + c for r, c in widest], dtype=np.int64)
    nodes: npt.NDArray[np.int64] = _place(
        free, order, minimum, step * math.sqrt(3.0) / 2.0, step, fill
    )
    return nodes


@njit(cache=True, nogil=True)
def _prune(skeleton: npt.NDArray[np.bool_], rounds: int) -> npt.NDArray[np.bool_]:
    """The skeleton without its spurs: ``rounds`` times, every end cell (one 8-neighbour) goes
    at once. Spurs shorter than that (into corners, off a wall's ragged edge) vanish; loops
    stay whole, and a dead end loses ``rounds`` cells, which a start there reaches straight."""
    H, W = skeleton.shape
    out = skeleton.copy()
    cells = np.flatnonzero(skeleton.ravel())
    ends = np.empty(cells.size, dtype=np.int64)
    for _ in range(rounds):
        n = 0
        for k in cells:
            r, c = k // W, k % W
            if not out[r, c]:
                continue
            around = 0
            for i in range(max(0, r - 1), min(H, r + 2)):
                for j in range(max(0, c - 1), min(W, c + 2)):
                    around += out[i, j]
            if around <= 2:  # itself and at most one neighbour
                ends[n] = k
                n += 1
        if n == 0:
            break
        for k in ends[:n]:
            out[k // W, k % W] = False
    return out


#: A chain bends where its two arms turn by more than this: 1 - cos(35 degrees).
BEND = 1.0 - math.cos(math.radians(35.0))


@njit(cache=True, nogil=True)
def _bends(
    free: npt.NDArray[np.bool_], skeleton: npt.NDArray[np.bool_], arm: int
) -> npt.NDArray[np.int64]:
    """Where chains bend, sharpest first (flat cells). A skeleton cell is a bend when, of its
    skeleton cells ``arm`` steps away (breadth first along the skeleton), two are more than
    ``arm`` cells apart and the directions to them turn by more than ``BEND``. Its node goes
    on the free cell nearest it (within ``arm``) that sees both arms ``4 * arm`` steps on (or
    to their ends): in a narrow corridor turning a corner, the corner, from where straight
    edges run down both arms (nodes either side of it would cut the corner; the medial axis
    itself rounds it off)."""
    H, W = skeleton.shape
    cells = np.flatnonzero(skeleton.ravel())
    stamp = np.zeros(H * W, dtype=np.int64)
    depth = np.zeros(H * W, dtype=np.int64)
    queue = np.empty((8 * arm + 3) ** 2, dtype=np.int64)
    found = np.empty(cells.size, dtype=np.int64)
    turn = np.empty(cells.size, dtype=np.float64)
    n = 0
    for i in range(cells.size):
        k = cells[i]
        r, c = k // W, k % W
        stamp[k], depth[k], queue[0] = i + 1, 0, k
        head, tail = 0, 1
        while head < tail:
            u = queue[head]
            head += 1
            if depth[u] == 4 * arm:
                continue
            ur, uc = u // W, u % W
            for vr in range(max(0, ur - 1), min(H, ur + 2)):
                for vc in range(max(0, uc - 1), min(W, uc + 2)):
                    v = vr * W + vc
                    if skeleton[vr, vc] and stamp[v] != i + 1 and tail < queue.size:
                        stamp[v], depth[v] = i + 1, depth[u] + 1
                        queue[tail] = v
                        tail += 1
        a, b, most = -1, -1, -1
        for j in range(tail):
            if depth[queue[j]] == arm:
                if a < 0:
                    a = queue[j]
                elif _sq(a, queue[j], W) > most:
                    b, most = queue[j], _sq(a, queue[j], W)
        if b < 0 or most <= arm * arm:
            continue  # no two arms
        ar, ac, br, bc = a // W - r, a % W - c, b // W - r, b % W - c
        cos = (ar * br + ac * bc) / math.sqrt((ar * ar + ac * ac) * (br * br + bc * bc))
        if 1.0 + cos <= BEND:
            continue
        fa, fb = a, b  # each arm's deepest cell
        for j in range(tail - 1, -1, -1):
            u = queue[j]
            if depth[u] <= arm:
                break
            if fa == a and _sq(u, a, W) < _sq(u, b, W):
                fa = u
            if fb == b and _sq(u, b, W) < _sq(u, a, W):
                fb = u
        if min(depth[fa], depth[fb]) < 2 * arm:
            continue  # a chain's end curling, not a bend between two lengths of chain
        found[n], turn[n] = k, -(1.0 + cos)
        best = arm * arm + 1
        for xr in range(max(0, r - arm), min(H, r + arm + 1)):
            for xc in range(max(0, c - arm), min(W, c + arm + 1)):
                d = (xr - r) ** 2 + (xc - c) ** 2
                if (
                    d < best
                    and free[xr, xc]
                    and segment_free(free, xr, xc, fa // W, fa % W)
                    and segment_free(free, xr, xc, fb // W, fb % W)
                ):
                    found[n], best = xr * W + xc, d
        n += 1
    return found[:n][np.argsort(turn[:n], kind="mergesort")]


@njit(cache=True, nogil=True)
def _sq(a: int, b: int, W: int) -> int:
    """The squared distance between flat cells ``a`` and ``b`` of a grid ``W`` wide."""
    return (a // W - b // W) ** 2 + (a % W - b % W) ** 2


@njit(cache=True, nogil=True)
def _chain_order(
    skeleton: npt.NDArray[np.bool_], clear: npt.NDArray[np.float64], bends: npt.NDArray[np.int64]
) -> npt.NDArray[np.int64]:
    """The skeleton's cells in the order chain nodes are tried: its junctions (three branches
    or more meet), widest first, so that crossings get nodes; then its ``bends``; then every
    cell breadth first from the first of each piece, so that a chain is walked along."""
    H, W = skeleton.shape
    ring_r = np.array([-1, -1, 0, 1, 1, 1, 0, -1])
    ring_c = np.array([0, 1, 1, 1, 0, -1, -1, -1])
    junctions = np.empty(H * W, dtype=np.int64)
    width = np.empty(H * W, dtype=np.float64)
    n = 0
    for r in range(H):
        for c in range(W):
            if not skeleton[r, c]:
                continue
            ends = 0
            for k in range(8):
                here = _on(skeleton, r + ring_r[k], c + ring_c[k])
                after = _on(skeleton, r + ring_r[(k + 1) % 8], c + ring_c[(k + 1) % 8])
                ends += here and not after
            if ends >= 3:
                junctions[n] = r * W + c
                width[n] = -clear[r, c]
                n += 1
    out = np.empty(H * W + n + bends.size, dtype=np.int64)
    out[:n] = junctions[:n][np.argsort(width[:n], kind="mergesort")]
    out[n : n + bends.size] = bends
    m = n + bends.size
    seen = np.zeros((H, W), dtype=np.bool_)
    for root in range(H * W):
        if not skeleton[root // W, root % W] or seen[root // W, root % W]:
            continue
        seen[root // W, root % W] = True
        out[m] = root
        head, m = m, m + 1
        while head < m:
            r, c = out[head] // W, out[head] % W
            head += 1
            for k in range(8):
                r2, c2 = r + ring_r[k], c + ring_c[k]
                if _on(skeleton, r2, c2) and not seen[r2, c2]:
                    seen[r2, c2] = True
                    out[m] = r2 * W + c2
                    m += 1
    return out[:m].copy()


@njit(cache=True, nogil=True)
def _on(grid: npt.NDArray[np.bool_], r: int, c: int) -> bool:
    return 0 <= r < grid.shape[0] and 0 <= c < grid.shape[1] and bool(grid[r, c])


@njit(cache=True, nogil=True)
def _near(
    grid: npt.NDArray[np.int64], size: int, W: int, r: int, c: int, minimum: float
) -> bool:  # fmt: skip
    """Whether a node marked in ``grid`` (bucket -> the node's flat cell, ``size`` cells a
    bucket: one node a bucket, as nodes are farther apart than a bucket's diagonal) is nearer
    than ``minimum`` to ``(r, c)``."""
    bh, bw = grid.shape[0], grid.shape[1]
    reach = math.ceil(minimum / size)
    minimum_sq = minimum * minimum
    br, bc = r // size, c // size
    for i in range(max(0, br - reach), min(bh, br + reach + 1)):
        for j in range(max(0, bc - reach), min(bw, bc + reach + 1)):
            k = grid[i, j]
            if k >= 0:
                dr, dc = k // W - r, k % W - c
                if dr * dr + dc * dc < minimum_sq:
                    return True
    return False


@njit(cache=True, nogil=True)
def _place(
    free: npt.NDArray[np.bool_],
    order: npt.NDArray[np.int64],
    minimum: float,
    row_step: float,
    col_step: float,
    fill: npt.NDArray[np.int64],
) -> npt.NDArray[np.int64]:
    """Nodes ``(n, 2)``: the cells of ``order`` (flat indices), then the triangular lattice's
    cells, then the cells of ``fill``, each kept when free and no kept node is nearer than
    ``minimum``."""
    H, W = free.shape
    size = max(1, int(minimum / math.sqrt(2.0)))  # a bucket's diagonal below the minimum
    grid = np.full((H // size + 1, W // size + 1), -1, dtype=np.int64)
    out = np.empty((H * W, 2), dtype=np.int64)
    n = 0
    for k in order:
        r, c = k // W, k % W
        if not _near(grid, size, W, r, c, minimum):
            grid[r // size, c // size] = k
            out[n, 0], out[n, 1] = r, c
            n += 1
    rows = int((H - 1) / row_step) + 1
    for i in range(rows):
        r = round(i * row_step)
        shift = col_step / 2.0 if i % 2 else 0.0
        j = 0
        while True:
            c = round(shift + j * col_step)
            j += 1
            if c >= W:
                break
            if free[r, c] and not _near(grid, size, W, r, c, minimum):
                grid[r // size, c // size] = r * W + c
                out[n, 0], out[n, 1] = r, c
                n += 1
    for k in fill:
        r, c = k // W, k % W
        if not _near(grid, size, W, r, c, minimum):
            grid[r // size, c // size] = k
            out[n, 0], out[n, 1] = r, c
            n += 1
    return out[:n].copy()

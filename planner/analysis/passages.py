"""Narrow passages: where free space narrows below ``max_width`` between wider spaces and a
round robot still fits, read on the medial axis (skeleton) of free space over the exact
distance transform.

Only obstacles at least ``min_wall`` across shape passages (scan specks and furniture legs do
not: :mod:`planner.analysis.walls`). A skeleton cell is a *neck* cell when its width (twice its
distance to the nearest such obstacle cell's center) is at most ``max_width``; connected neck
cells form a neck, and a neck is a passage when it opens onto wider skeleton (width >
``max_width``) at two separate mouths, the widest way between two of them stays wider than the
robot, and at its narrowest point there are walls on two sides. Dead ends (one mouth), pinches
too narrow for the robot, open rooms (no neck) and the band between a wall and unknown space or a
speck are not passages.

>>> from planner.maps.robot_maps import grid_map
>>> rows = [[0] * 9 for _ in range(9)]
>>> for r in range(9):
...     rows[r][4] = 0 if r == 4 else 1  # a wall down the middle with a one-cell door
>>> (door,) = find_passages(grid_map(rows, resolution=0.1), robot_radius=0.05, max_width=0.3)
>>> (door.row, door.col, round(door.width_m, 2))
(4, 4, 0.2)
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit
from scipy import ndimage

from planner.analysis.cspace import CSpace, configuration_space
from planner.analysis.distance import squared_distances
from planner.analysis.medial import medial_axis
from planner.analysis.walls import MIN_WALL, find_walls, two_sided
from planner.errors import InvalidInput, quote
from planner.maps.frames import MapFrame
from planner.maps.robot_maps import RobotMap

__all__ = ["Passage", "crossed_passages", "find_passages", "path_narrowest"]

#: Slack added to ``2 * robot_radius`` for the default ``max_width``, in meters.
MAX_WIDTH_SLACK = 0.3

#: A neck's skeleton may rise less than this above ``max_width / 2`` (in cells, as a
#: distance) and still be one neck (see ``_passages``).
HYSTERESIS = 0.5

_EIGHT = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True)
class Passage:
    """One narrow passage.

    ``id``: 0..n-1 in the order of ``(row, col)`` of the narrowest cell; ``(x, y)``: that
    cell's center in meters (map frame); ``width_m``: the width there, center to center (twice
    the distance to the nearest blocked cell's center); ``length_m``: how far along the passage
    the width stays below ``max_width``; ``cells``: flat indices (``row * width + col``) of the
    traversable cells of the neck (its skeleton and the cells across it).
    """

    id: int
    x: float
    y: float
    width_m: float
    length_m: float
    row: int
    col: int
    cells: npt.NDArray[np.int64]


def find_passages(
    robot_map: RobotMap,
    robot_radius: float,
    max_width: float | None = None,
    *,
    min_wall: float = MIN_WALL,
) -> tuple[Passage, ...]:
    """The narrow passages of ``robot_map`` for a round robot of ``robot_radius`` meters:
    necks at most ``max_width`` meters wide (default ``2 * robot_radius + 0.3``) between wider
    spaces, wider than the robot, between walls at least ``min_wall`` meters across. Unknown
    cells and the outside of the map count as blocked, but are no walls."""
    radius = _meters(robot_radius, "robot_radius")
    least = _meters(min_wall, "min_wall")
    if least < 0:
        raise InvalidInput(f"min_wall must be >= 0 meters; got {quote(min_wall)}", field="min_wall")
    if radius < 0:
        raise InvalidInput(
            f"robot_radius must be >= 0 meters; got {quote(robot_radius)}", field="robot_radius"
        )
    if max_width is None:
        widest = 2 * radius + MAX_WIDTH_SLACK
    else:
        widest = _meters(max_width, "max_width")
        if widest <= 2 * radius:
            raise InvalidInput(
                f"max_width must be more than the robot's diameter 2 * robot_radius = "
                f"{2 * radius:g} m; got {quote(max_width)}",
                field="max_width",
            )
    cspace = configuration_space(robot_map, robot_radius=radius, unknown="blocked")
    return _passages(robot_map, cspace, widest, least)


def crossed_passages(
    passages: tuple[Passage, ...], path: Any, shape: tuple[int, int]
) -> tuple[int, ...]:
    """The ids of the passages a path of ``[row, col]`` cells enters, in the order it enters
    them (a passage left and entered again counts again)."""
    cells = np.asarray(path, dtype=np.int64).reshape(-1, 2)
    if not passages or not len(cells):
        return ()
    flat = np.concatenate([p.cells for p in passages])
    ids = np.concatenate([np.full(p.cells.size, p.id, dtype=np.int64) for p in passages])
    order = np.argsort(flat, kind="stable")
    flat, ids = flat[order], ids[order]
    wanted = cells[:, 0] * shape[1] + cells[:, 1]
    at = np.minimum(np.searchsorted(flat, wanted), flat.size - 1)
    owner = np.where(flat[at] == wanted, ids[at], -1)
    out: list[int] = []
    last = -1
    for here in owner.tolist():
        if here >= 0 and here != last:
            out.append(here)
        last = here
    return tuple(out)


def path_narrowest(cspace: CSpace, frame: MapFrame, path: Any) -> tuple[float, float, float]:
    """The narrowest point a path of ``[row, col]`` cells crosses: ``(x, y, width_m)``, the
    center of its cell nearest to a blocked cell (the first such along the path) and twice that
    distance, center to center.

    >>> from planner.maps.robot_maps import grid_map
    >>> m = grid_map([[0, 0, 0], [1, 0, 1], [0, 0, 0]], resolution=0.5)
    >>> cs = configuration_space(m, unknown="free")  # the outside of the map free
    >>> path_narrowest(cs, m.frame, [[0, 1], [1, 1], [2, 1]])
    (0.75, 0.75, 1.0)
    """
    cells = np.asarray(path, dtype=np.int64).reshape(-1, 2)
    if not len(cells):
        raise InvalidInput("path must hold at least one cell; got none", field="path")
    here = int(np.argmin(cspace.distance[cells[:, 0], cells[:, 1]]))
    (x, y), *_ = frame.centers(cells[here : here + 1]).tolist()
    width = 2.0 * float(cspace.distance[cells[here, 0], cells[here, 1]]) * cspace.resolution
    return float(x), float(y), width


def _meters(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise InvalidInput(f"{field} must be a number of meters; got {quote(value)}", field=field)
    if not math.isfinite(float(value)):
        raise InvalidInput(f"{field} must be finite; got {quote(value)}", field=field)
    return float(value)


def _passages(
    robot_map: RobotMap, cspace: CSpace, max_width: float, min_wall: float
) -> tuple[Passage, ...]:
    H, W = robot_map.shape
    res = cspace.resolution
    walls = find_walls(robot_map.occupancy, res, min_wall, cspace.occupied_threshold)
    free = np.ascontiguousarray(~walls.obstacles)
    # The outside of the map counts as blocked, for the distances and for the skeleton.
    distance = squared_distances(free, outside_blocked=True)
    np.sqrt(distance, out=distance)  # in place: no second float64 array of the map
    skeleton = medial_axis(free, distance)
    limit = max_width / res / 2  # in cells, as a distance
    tolerance = 1e-9 * max(1.0, limit)
    below = distance <= limit + tolerance  # a passage exactly max_width wide is one
    # A neck runs on while the skeleton stays within HYSTERESIS of max_width: a corridor about
    # max_width wide whose walls wiggle by a cell is one neck, not a neck at every wiggle.
    near = distance < limit + HYSTERESIS - tolerance
    fits = cspace.robot_radius / res * (1 + 1e-9)
    wide = skeleton & ~near
    labels, count = ndimage.label(skeleton & near, structure=_EIGHT)
    narrow = np.bincount(labels[skeleton & below], minlength=count + 1) > 0
    mouthed = _beside_counts(labels, wide, count) >= 2  # one wide cell beside: one mouth at most
    reach = 2 + math.ceil(limit / 2)
    found: list[tuple[int, int, float, float, npt.NDArray[np.int64]]] = []
    for index, box in enumerate(ndimage.find_objects(labels), start=1):
        if box is None or not narrow[index] or not mouthed[index]:
            continue
        # Two cells around the neck: its mouths, and the cells beside its skeleton.
        r0, r1 = max(box[0].start - 2, 0), min(box[0].stop + 2, H)
        c0, c1 = max(box[1].start - 2, 0), min(box[1].stop + 2, W)
        mine = labels[r0:r1, c0:c1] == index
        beside = ndimage.binary_dilation(mine, structure=_EIGHT)
        # Its mouths: the wider skeleton beside it, one mouth where that skeleton joins within
        # ``reach`` cells of the neck (round its end), two where it does not (across the neck).
        R0, C0 = max(box[0].start - reach, 0), max(box[1].start - reach, 0)
        joined, _ = ndimage.label(
            wide[R0 : box[0].stop + reach, C0 : box[1].stop + reach], structure=_EIGHT
        )
        joined = joined[r0 - R0 : r1 - R0, c0 - C0 : c1 - C0]
        touching = wide[r0:r1, c0:c1] & beside
        groups = np.unique(joined[touching])
        if groups.size < 2:
            continue
        mouths = np.zeros(mine.shape, dtype=np.int32)
        mouths[touching] = np.searchsorted(groups, joined[touching]) + 1
        band = (beside & free[r0:r1, c0:c1] & near[r0:r1, c0:c1]) | (mouths > 0)
        local = distance[r0:r1, c0:c1]
        saddle = _saddle(band, mouths, local, fits)
        if saddle is None or not below[saddle[0] + r0, saddle[1] + c0]:
            continue  # the robot passes nowhere, or the widest way is wider than max_width
        row, col = saddle
        if not two_sided(walls.walls, row + r0, col + c0, float(local[row, col])):
            continue
        core = below[r0:r1, c0:c1]
        rows, cols = np.nonzero(mine & core)
        grown = _grown(band & ~core, mouths)
        length = _length(band & (grown == 0), grown) * res
        ways = band & (grown == 0) & (cspace.traversable[r0:r1, c0:c1] == 1)
        br, bc = np.nonzero(ways)
        cells = np.union1d(
            _across(rows + r0, cols + c0, distance, cspace.traversable), (br + r0) * W + bc + c0
        ).astype(np.int64)
        found.append((row + r0, col + c0, 2.0 * float(local[row, col]) * res, length, cells))
    found.sort(key=lambda f: (f[0], f[1]))
    centers = robot_map.frame.centers([[f[0], f[1]] for f in found]).reshape(-1, 2)
    return tuple(
        Passage(
            id=i,
            x=float(centers[i][0]),
            y=float(centers[i][1]),
            width_m=width,
            length_m=length,
            row=row,
            col=col,
            cells=cells,
        )
        for i, (row, col, width, length, cells) in enumerate(found)
    )


def _grown(outer: npt.NDArray[np.bool_], mouths: npt.NDArray[np.int32]) -> npt.NDArray[np.int32]:
    """The mouths grown over the ``outer`` cells joined to them (a neck's cells wider than
    ``max_width``, within the hysteresis): the neck's length and cells are where it is at most
    ``max_width`` wide."""
    parts, count = ndimage.label(outer | (mouths > 0), structure=_EIGHT)
    owner = np.zeros(count + 1, dtype=np.int32)
    owner[parts[mouths > 0]] = mouths[mouths > 0]
    out: npt.NDArray[np.int32] = owner[parts]
    return out


def _beside_counts(
    labels: npt.NDArray[np.int32], wide: npt.NDArray[np.bool_], count: int
) -> npt.NDArray[np.int64]:
    """For each label 0..count, how many ``wide`` cells are beside (8-connected) its cells."""
    H, W = labels.shape
    padded = np.pad(labels, 1)
    rows, cols = np.nonzero(wide)
    flat = (rows * W + cols).astype(np.int64)
    pairs = np.concatenate(
        [
            padded[rows + 1 + dr, cols + 1 + dc].astype(np.int64) * (H * W) + flat
            for dr in (-1, 0, 1)
            for dc in (-1, 0, 1)
        ]
    )
    owners = np.unique(pairs) // (H * W)
    return np.bincount(owners, minlength=count + 1)


def _saddle(
    band: npt.NDArray[np.bool_],
    mouths: npt.NDArray[np.int32],
    distance: npt.NDArray[np.float64],
    fits: float,
) -> tuple[int, int] | None:
    """The narrowest point on the widest ways between the mouths, through the ``band`` of cells
    along the neck (see :func:`_saddle_kernel`), centered among the equally narrow cells around
    it; None when the robot passes no way between two mouths."""
    rows, cols = np.nonzero(band)
    order = np.lexsort((cols, rows, -distance[rows, cols]))
    flat = (rows[order] * band.shape[1] + cols[order]).astype(np.int64)
    best = _saddle_kernel(
        np.ascontiguousarray(mouths, dtype=np.int32),
        np.ascontiguousarray(distance),
        flat,
        float(fits),
        int(mouths.max()),
    )
    if best < 0:
        return None
    return _middle(divmod(int(best), band.shape[1]), band, distance)


@njit(cache=True, nogil=True)
def _root(parent: npt.NDArray[np.int64], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True, nogil=True)
def _saddle_kernel(
    mouths: npt.NDArray[np.int32],
    distance: npt.NDArray[np.float64],
    order: npt.NDArray[np.int64],
    fits: float,
    groups: int,
) -> int:
    """Union-find over the cells of ``order`` (flat indices, by decreasing distance): each cell
    joins its already-joined neighbours; the cells of one mouth are one set from the start (the
    wide space joins them). When a cell joins two sets that each hold a mouth, two groups of
    mouths first meet there: it is the bottleneck of the widest way between them. The last such
    cell with distance > ``fits`` (the narrowest bottleneck the robot passes), or -1."""
    H, W = mouths.shape
    parent = np.full(H * W, -1, dtype=np.int64)
    holds = np.zeros(H * W, dtype=np.bool_)
    first = np.full(groups + 1, -1, dtype=np.int64)
    best = -1
    for k in range(order.size):
        here = order[k]
        r, c = here // W, here % W
        parent[here] = here
        g = mouths[r, c]
        if g > 0:
            holds[here] = True
            if first[g] < 0:
                first[g] = here
            else:
                parent[here] = _root(parent, first[g])
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                r2, c2 = r + dr, c + dc
                if (dr == 0 and dc == 0) or not (0 <= r2 < H and 0 <= c2 < W):
                    continue
                there = r2 * W + c2
                if parent[there] < 0:
                    continue
                a, b = _root(parent, here), _root(parent, there)
                if a == b:
                    continue
                if holds[a] and holds[b] and distance[r, c] > fits:
                    best = here
                parent[b] = a
                holds[a] = holds[a] or holds[b]
    return best


def _middle(
    cell: tuple[int, int], band: npt.NDArray[np.bool_], distance: npt.NDArray[np.float64]
) -> tuple[int, int]:
    """Among the band's cells as narrow as ``cell`` and joined to it (a door through a thick
    wall), the one nearest their middle, then the first by ``(row, col)``."""
    ties, _ = ndimage.label(band & (distance == distance[cell]), structure=_EIGHT)
    tr, tc = np.nonzero(ties == ties[cell])
    mr, mc = tr.mean(), tc.mean()
    order = np.lexsort((tc, tr, (tr - mr) ** 2 + (tc - mc) ** 2))
    return int(tr[order[0]]), int(tc[order[0]])


def _length(neck: npt.NDArray[np.bool_], mouths: npt.NDArray[np.int32]) -> float:
    """How long the neck is, in cells (see :func:`_length_kernel`)."""
    return float(
        _length_kernel(
            np.ascontiguousarray(neck, dtype=np.uint8),
            np.ascontiguousarray(mouths, dtype=np.int32),
            int(mouths.max()),
        )
    )


@njit(cache=True, nogil=True)
def _length_kernel(
    neck: npt.NDArray[np.uint8], mouths: npt.NDArray[np.int32], groups: int
) -> float:
    """The longest of the shortest ways through the ``neck`` cells from one mouth to another
    (Dijkstra from each mouth's cells, diagonal steps sqrt(2)), mouth cell to mouth cell.
    Through the band along the skeleton rather than on it: a skeleton zigzags between two
    equally central rows."""
    H, W = neck.shape
    longest = 0.0
    best = np.empty((H, W))
    for g in range(1, groups):
        best[:] = np.inf
        heap = [(0.0, np.int64(0))]
        heap.pop()
        for r in range(H):
            for c in range(W):
                if mouths[r, c] == g:
                    best[r, c] = 0.0
                    heapq.heappush(heap, (0.0, np.int64(r * W + c)))
        while len(heap) > 0:
            d, here = heapq.heappop(heap)
            r, c = here // W, here % W
            if d > best[r, c] or not (neck[r, c] or mouths[r, c] == g):
                continue  # stale, or another mouth reached: the way ends there
            for dr in range(-1, 2):
                for dc in range(-1, 2):
                    r2, c2 = r + dr, c + dc
                    if (dr == 0 and dc == 0) or not (0 <= r2 < H and 0 <= c2 < W):
                        continue
                    if not (neck[r2, c2] or mouths[r2, c2] > 0):
                        continue
                    nd = d + (math.sqrt(2.0) if dr != 0 and dc != 0 else 1.0)
                    if nd < best[r2, c2]:
                        best[r2, c2] = nd
                        heapq.heappush(heap, (nd, np.int64(r2 * W + c2)))
        for h in range(g + 1, groups + 1):
            least = np.inf
            for r in range(H):
                for c in range(W):
                    if mouths[r, c] == h and best[r, c] < least:
                        least = best[r, c]
            if least < np.inf and least > longest:
                longest = least
    return longest


def _across(
    rows: npt.NDArray[np.intp],
    cols: npt.NDArray[np.intp],
    distance: npt.NDArray[np.float64],
    traversable: npt.NDArray[np.uint8],
) -> npt.NDArray[np.int64]:
    """The traversable cells of the neck: those within each skeleton cell's clearance disk (the
    free space the skeleton stands for), as sorted flat indices."""
    H, W = distance.shape
    reach = math.ceil(float(distance[rows, cols].max()))
    r0, r1 = max(int(rows.min()) - reach, 0), min(int(rows.max()) + reach + 1, H)
    c0, c1 = max(int(cols.min()) - reach, 0), min(int(cols.max()) + reach + 1, W)
    inside = np.zeros((r1 - r0, c1 - c0), dtype=bool)
    yy, xx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    for r, c in zip(rows.tolist(), cols.tolist(), strict=True):
        disk = yy**2 + xx**2 < distance[r, c] ** 2
        lr, lc = r - reach - r0, c - reach - c0
        sr0, sc0 = max(lr, 0), max(lc, 0)
        sr1 = min(lr + 2 * reach + 1, inside.shape[0])
        sc1 = min(lc + 2 * reach + 1, inside.shape[1])
        inside[sr0:sr1, sc0:sc1] |= disk[sr0 - lr : sr1 - lr, sc0 - lc : sc1 - lc]
    inside &= traversable[r0:r1, c0:c1] == 1
    local_r, local_c = np.nonzero(inside)
    flat: npt.NDArray[np.int64] = ((local_r + r0) * W + (local_c + c0)).astype(np.int64)
    return flat

"""A slow, obvious reference of the narrow passages: brute-force nearest blocked cells, medial
points where the nearest blocked cell jumps between neighbours, necks grouped by a breadth-first
walk, and mouths onto wide free space."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

EIGHT = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


@dataclass
class RefPassage:
    width_cells: float  # twice the smallest distance on the neck, in cells
    narrowest: list[tuple[int, int]]  # the neck cells of that smallest distance
    neck: set[tuple[int, int]]  # the neck's medial cells


def nearest_blocked(blocked: np.ndarray, reach: int) -> np.ndarray:
    """For every cell, the distance (cells) to the nearest blocked cell's center within
    ``reach`` cells (the outside of the map counts as blocked; +inf when none is that near), by
    trying every offset of the window in order of distance."""
    H, W = blocked.shape
    padded = np.ones((H + 2 * reach + 2, W + 2 * reach + 2), dtype=bool)
    padded[reach + 1 : reach + 1 + H, reach + 1 : reach + 1 + W] = blocked
    offsets = sorted(
        (
            (dr * dr + dc * dc, dr, dc)
            for dr in range(-reach, reach + 1)
            for dc in range(-reach, reach + 1)
        ),
    )
    dist = np.full((H, W), math.inf)
    for sq, dr, dc in offsets:
        if sq > reach * reach:
            continue
        r0, c0 = reach + 1 + dr, reach + 1 + dc
        hit = padded[r0 : r0 + H, c0 : c0 + W] & np.isinf(dist)
        dist[hit] = math.sqrt(sq)
    return dist


def medial(blocked: np.ndarray, dist: np.ndarray, within: np.ndarray) -> np.ndarray:
    """The cells of ``within`` whose nearest blocked cells lie on two separate sides: the blocked
    cells within ``d + 1`` of the cell (its nearest ones, to one cell) fall in two or more groups
    that do not touch (8-connected) - two walls, a wall and a pillar, a door's two jambs - rather
    than one stretch of one wall."""
    H, W = blocked.shape
    out = np.zeros((H, W), dtype=bool)
    for r, c in zip(*np.nonzero(within), strict=True):
        near = dist[r, c] + 1
        k = math.ceil(near)
        near_set = {
            (r + dr, c + dc)
            for dr in range(-k, k + 1)
            for dc in range(-k, k + 1)
            if math.hypot(dr, dc) <= near + 1e-9
            and (not (0 <= r + dr < H and 0 <= c + dc < W) or blocked[r + dr, c + dc])
        }
        out[r, c] = groups(near_set, 1) >= 2
    return out


def passages(
    occupancy: np.ndarray,
    resolution: float,
    robot_radius: float,
    max_width: float,
    min_wall: float = 0.2,
) -> list[RefPassage]:
    """The passages: connected medial cells less than half a cell wider than ``max_width``, one of
    them at most ``max_width``, whose neighbours reach wide free cells (wider than that) at two
    places not joined by wide free cells near the neck, whose widest way between two such mouths
    stays wider than the robot and at most ``max_width``, with walls on two sides there. Only
    obstacles at least ``min_wall`` across count; only occupied ones are walls."""
    occupied = occupancy >= 65
    walls = big(occupied, resolution, min_wall)
    blocked = big(occupied | (occupancy < 0), resolution, min_wall)
    limit = max_width / resolution / 2  # a distance, in cells
    loose = limit + 0.5
    fits = robot_radius / resolution
    reach = math.ceil(loose) + 2
    dist = nearest_blocked(blocked, reach)
    H, W = blocked.shape
    neck = medial(blocked, dist, ~blocked & (dist < loose - 1e-9))
    wide = ~blocked & (dist >= loose - 1e-9)
    apart = 2 + math.ceil(limit / 2)
    seen: set[tuple[int, int]] = set()
    out = []
    for r, c in zip(*np.nonzero(neck), strict=True):
        if (r, c) in seen:
            continue
        comp = {(int(r), int(c))}
        queue = deque(comp)
        while queue:
            a, b = queue.popleft()
            for dr, dc in EIGHT:
                n = (a + dr, b + dc)
                if 0 <= n[0] < H and 0 <= n[1] < W and neck[n] and n not in comp:
                    comp.add(n)
                    queue.append(n)
        seen |= comp
        if all(dist[p] > limit + 1e-9 for p in comp):
            continue
        contacts = {
            (a + dr, b + dc)
            for a, b in comp
            for dr, dc in EIGHT
            if 0 <= a + dr < H and 0 <= b + dc < W and wide[a + dr, b + dc]
        }
        rows, cols = [p[0] for p in comp], [p[1] for p in comp]
        box = (min(rows) - apart, max(rows) + apart, min(cols) - apart, max(cols) + apart)
        mouths = joined(contacts, wide, box)
        ways = [
            widest(comp, dist, mouths[i], mouths[j])
            for i in range(len(mouths))
            for j in range(i + 1, len(mouths))
        ]
        passable = [w for w in ways if w > fits * (1 + 1e-9)]
        if not passable or min(passable) > limit + 1e-9:
            continue
        least = min(passable)
        narrowest = sorted(p for p in comp if dist[p] == least)
        if not any(sided(walls, p, least) for p in narrowest):
            continue
        out.append(RefPassage(2 * least, narrowest, comp))
    return out


def big(cells: np.ndarray, resolution: float, min_wall: float) -> np.ndarray:
    """The cells of the 8-connected groups of ``cells`` whose bounding box's longer side is at
    least ``min_wall`` meters (in whole cells), by flood fill."""
    H, W = cells.shape
    out = np.zeros((H, W), dtype=bool)
    seen = np.zeros((H, W), dtype=bool)
    for r, c in zip(*np.nonzero(cells), strict=True):
        if seen[r, c]:
            continue
        group = [(int(r), int(c))]
        seen[r, c] = True
        queue = deque(group)
        while queue:
            a, b = queue.popleft()
            for dr, dc in EIGHT:
                n = (a + dr, b + dc)
                if 0 <= n[0] < H and 0 <= n[1] < W and cells[n] and not seen[n]:
                    seen[n] = True
                    group.append(n)
                    queue.append(n)
        tall = max(p[0] for p in group) - min(p[0] for p in group) + 1
        broad = max(p[1] for p in group) - min(p[1] for p in group) + 1
        if max(tall, broad) * resolution >= min_wall * (1 - 1e-9):
            for p in group:
                out[p] = True
    return out


def joined(
    contacts: set[tuple[int, int]], wide: np.ndarray, box: tuple[int, int, int, int]
) -> list[set[tuple[int, int]]]:
    """``contacts`` in groups: two in one when a walk through ``wide`` cells inside ``box``
    (rows r0..r1, columns c0..c1, inclusive) joins them."""
    r0, r1, c0, c1 = box
    left = set(contacts)
    out = []
    while left:
        start = left.pop()
        reached = {start}
        queue = deque(reached)
        while queue:
            a, b = queue.popleft()
            for dr, dc in EIGHT:
                n = (a + dr, b + dc)
                if (
                    r0 <= n[0] <= r1
                    and c0 <= n[1] <= c1
                    and 0 <= n[0] < wide.shape[0]
                    and 0 <= n[1] < wide.shape[1]
                    and wide[n]
                    and n not in reached
                ):
                    reached.add(n)
                    queue.append(n)
        out.append({start} | (left & reached))
        left -= reached
    return out


def sided(walls: np.ndarray, cell: tuple[int, int], d: float) -> bool:
    """Whether two wall cells within ``d + 1.5`` cells of ``cell`` have a segment between them
    passing within ``d / 2`` of it, trying every pair."""
    r, c = cell
    k = math.ceil(d + 1.5)
    near = [
        (dr, dc)
        for dr in range(-k, k + 1)
        for dc in range(-k, k + 1)
        if math.hypot(dr, dc) <= d + 1.5 + 1e-9
        and 0 <= r + dr < walls.shape[0]
        and 0 <= c + dc < walls.shape[1]
        and walls[r + dr, c + dc]
    ]

    def closest(a: tuple[int, int], b: tuple[int, int]) -> float:
        """The distance from the cell to the segment a-b (offsets from the cell)."""
        ur, uc = b[0] - a[0], b[1] - a[1]
        t = max(0.0, min(1.0, -(a[0] * ur + a[1] * uc) / (ur * ur + uc * uc)))
        return math.hypot(a[0] + t * ur, a[1] + t * uc)

    return any(closest(a, b) <= d / 2 + 1e-9 for j, a in enumerate(near) for b in near[j + 1 :])


def widest(
    cells: set[tuple[int, int]],
    dist: np.ndarray,
    source: set[tuple[int, int]],
    target: set[tuple[int, int]],
) -> float:
    """The largest ``d`` such that a way through ``cells`` from a cell next to ``source`` to a
    cell next to ``target`` keeps every cell's distance >= ``d`` (0 when there is no way)."""
    values = sorted({float(dist[p]) for p in cells}, reverse=True)
    for d in values:
        ok = {p for p in cells if dist[p] >= d}
        start = {p for p in ok if any((p[0] + a, p[1] + b) in source for a, b in EIGHT)}
        queue = deque(start)
        reached = set(start)
        while queue:
            a, b = queue.popleft()
            for dr, dc in EIGHT:
                n = (a + dr, b + dc)
                if n in ok and n not in reached:
                    reached.add(n)
                    queue.append(n)
        if any((p[0] + a, p[1] + b) in target for p in reached for a, b in EIGHT):
            return d
    return 0.0


def split(cells: set[tuple[int, int]], apart: int) -> list[set[tuple[int, int]]]:
    """``cells`` in groups, two cells within Chebyshev distance ``apart`` in one."""
    left = set(cells)
    out = []
    while left:
        group = {left.pop()}
        queue = deque(group)
        while queue:
            a, b = queue.popleft()
            near = {p for p in left if max(abs(p[0] - a), abs(p[1] - b)) <= apart}
            left -= near
            group |= near
            queue.extend(near)
        out.append(group)
    return out


def groups(cells: set[tuple[int, int]], apart: int) -> int:
    """How many groups ``cells`` make, two cells within Chebyshev distance ``apart`` in one."""
    return len(split(cells, apart))


def medial_axis(free: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """scikit-image's medial axis written out: free cells visited by increasing distance, then
    by how few free cells their 3 x 3 neighbourhood holds (more "cornery" first), then in the
    order of ``default_rng(0).permutation``; each is removed unless its neighbourhood (the
    outside empty) has fewer than three free cells or loses or gains a connected group without
    it."""
    H, W = free.shape
    out = free.copy()
    cells = [(r, c) for r in range(H) for c in range(W) if free[r, c]]
    tiebreak = np.random.default_rng(0).permutation(len(cells))

    def around(r: int, c: int) -> list[tuple[int, int]]:
        return [
            (r + dr, c + dc)
            for dr in (-1, 0, 1)
            for dc in (-1, 0, 1)
            if 0 <= r + dr < H and 0 <= c + dc < W and free[r + dr, c + dc]
        ]

    def key(i: int) -> tuple[int, int, int]:
        r, c = cells[i]
        return round(float(dist[r, c]) ** 2), 9 - len(around(r, c)), int(tiebreak[i])

    for i in sorted(range(len(cells)), key=key):
        r, c = cells[i]
        with_it = {(a, b) for a, b in around(r, c) if out[a, b]} | {(r, c)}
        without = with_it - {(r, c)}
        keep = len(with_it) < 3 or groups(with_it, 1) != groups(without, 1)
        out[r, c] = keep
    return out

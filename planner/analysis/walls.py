"""Walls for the narrow passages: the obstacles big enough to make one. A scan speck or a
furniture leg is a few cells; a passage needs real walls on both sides, not the gap between a
wall and a speck, nor between a wall and unmapped space.

- An *obstacle* is a connected group (8-connected) of blocked cells: occupied or unknown.
- A *wall* is a connected group of occupied cells at least ``min_wall`` meters across (the longer
  side of its bounding box, counted in whole cells: a single cell of a 1 m map is 1 m across).

>>> import numpy as np
>>> occupancy = np.zeros((5, 8), dtype=np.int8)
>>> occupancy[0, :] = 100  # a wall along the top
>>> occupancy[3, 2] = 100  # a speck
>>> found = find_walls(occupancy, resolution=0.1, min_wall=0.25)
>>> found.walls.sum(), found.obstacles.sum()
(np.int64(8), np.int64(8))
>>> two_sided(found.walls, 2, 4, 2.0), two_sided(found.walls, 1, 4, 1.0)
(False, False)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage

__all__ = ["MIN_WALL", "Walls", "find_walls", "two_sided"]

#: The least extent of a wall, in meters: a pillar (0.3 m) is one, a scan speck or a chair's
#: leg (a few centimeters) is not.
MIN_WALL = 0.2

_EIGHT = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True)
class Walls:
    """``walls``: occupied cells of walls; ``obstacles``: blocked cells (occupied or unknown)
    of obstacles at least ``min_wall`` across, the only ones that shape passages."""

    walls: npt.NDArray[np.bool_]
    obstacles: npt.NDArray[np.bool_]


def find_walls(
    occupancy: npt.NDArray[np.int8],
    resolution: float,
    min_wall: float = MIN_WALL,
    occupied_threshold: int = 65,
) -> Walls:
    """The walls and big obstacles of an occupancy grid (``-1`` unknown, ``0..100``)."""
    occupied = occupancy >= occupied_threshold
    return Walls(
        walls=_big(occupied, resolution, min_wall),
        obstacles=_big(occupied | (occupancy < 0), resolution, min_wall),
    )


def two_sided(walls: npt.NDArray[np.bool_], row: int, col: int, distance: float) -> bool:
    """Whether cell ``(row, col)``, whose nearest blocked cells are ``distance`` cells away,
    stands between two walls: two wall cells within ``distance + 1.5`` cells of it (the other
    side can be up to a cell farther on a grid) such that the segment between them passes
    within ``distance / 2`` of it. Two cells of one straight wall do not: their segment runs
    along the wall, ``distance`` away."""
    H, W = walls.shape
    reach = distance + 1.5
    k = math.ceil(reach)
    r0, r1, c0, c1 = max(row - k, 0), min(row + k + 1, H), max(col - k, 0), min(col + k + 1, W)
    rows, cols = np.nonzero(walls[r0:r1, c0:c1])
    points = np.stack([rows + r0 - row, cols + c0 - col], axis=1).astype(np.float64)
    points = points[np.hypot(points[:, 0], points[:, 1]) <= reach + 1e-9]
    if len(points) < 2:
        return False
    a, b = points[:, None, :], points[None, :, :]
    step = b - a
    length = np.maximum((step**2).sum(axis=2), 1e-12)
    t = np.clip(-(a * step).sum(axis=2) / length, 0.0, 1.0)
    closest = np.hypot(*np.moveaxis(a + t[..., None] * step, 2, 0))
    return bool(closest.min() <= distance / 2 + 1e-9)


def _big(cells: npt.NDArray[np.bool_], resolution: float, min_wall: float) -> npt.NDArray[np.bool_]:
    """The cells of the 8-connected groups of ``cells`` at least ``min_wall`` meters across."""
    labels, count = ndimage.label(cells, structure=_EIGHT)
    keep = np.zeros(count + 1, dtype=bool)
    for index, box in enumerate(ndimage.find_objects(labels), start=1):
        if box is not None:
            across = max(box[0].stop - box[0].start, box[1].stop - box[1].start) * resolution
            keep[index] = across >= min_wall * (1 - 1e-9)
    out: npt.NDArray[np.bool_] = keep[labels]
    return out

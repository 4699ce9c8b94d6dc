"""A built map for the passages: rooms in a row joined by doors of known free gaps."""

from __future__ import annotations

import numpy as np

import planner

RESOLUTION = 0.05
GAPS = (0.35, 0.55, 0.75, 0.95, 1.6)  # the doors' free gaps, meters
ROOM = 3.0  # each room's side, meters
WALL = 0.1  # wall thickness, meters
ORIGIN = (-2.0, 1.0, 0.0)


def doors_grid(
    gaps: tuple[float, ...] = GAPS,
    *,
    wall: float = WALL,
    room: float = ROOM,
    unknown_walls: bool = False,
) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """The grid (0 free, 1 blocked, or -1 for the walls between rooms with ``unknown_walls``)
    and each door's middle as (row, col), fractional: rooms of ``room`` meters side by side,
    the wall between room i and i + 1 holding a door of free gap ``gaps[i]``."""
    n, t = round(room / RESOLUTION), round(wall / RESOLUTION)
    grid = np.zeros((n + 2, (n + t) * (len(gaps) + 1) - t + 2), dtype=np.int8)
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 1
    middles = []
    for i, gap in enumerate(gaps):
        c0 = 1 + (i + 1) * n + i * t
        grid[1:-1, c0 : c0 + t] = -1 if unknown_walls else 1
        k = round(gap / RESOLUTION)
        r0 = 1 + (n - k) // 2
        grid[r0 : r0 + k, c0 : c0 + t] = 0
        middles.append((r0 + (k - 1) / 2, c0 + (t - 1) / 2))
    return grid, middles


def doors_map(
    gaps: tuple[float, ...] = GAPS, *, wall: float = WALL, unknown_walls: bool = False
) -> planner.RobotMap:
    """:func:`doors_grid` as a robot map, its origin away from zero."""
    grid, _ = doors_grid(gaps, wall=wall, unknown_walls=unknown_walls)
    return planner.grid_map(grid, resolution=RESOLUTION, origin=ORIGIN)

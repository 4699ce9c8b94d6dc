"""The fleet benchmark's scenarios (benchmarks/fleet.py): maps of two rooms joined by a one-lane
corridor (fixed, or of random sizes) with robots swapping rooms through it, random robots on a
shared ROS map, and a map as the body of ``POST /maps``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import ndimage

import planner

CORRIDOR_RADIUS = 0.325
"""The robots of the corridor scenarios (meters): a 0.8 m lane holds one of them at a time."""
ROS_RADIUS = 0.22


def corridor_map(
    *,
    resolution: float = 0.1,
    lane_m: float = 0.8,
    length_m: float = 2.0,
    room_m: float = 4.0,
    right_m: float | None = None,
) -> planner.RobotMap:
    """Two rooms (squares of ``room_m``, the right one ``right_m`` if given) joined by a straight
    one-lane corridor ``lane_m`` wide (free cells between wall cells' centers: the lane's width)
    and ``length_m`` long, in the middle of their facing walls; walls one cell thick around."""
    room = round(room_m / resolution)
    other = room if right_m is None else round(right_m / resolution)
    lane = max(1, round(lane_m / resolution) - 1)
    lane += 1 - lane % 2  # odd: a cell on the lane's middle
    length = round(length_m / resolution)
    h, w = max(room, other) + 2, room + other + length + 2
    occ = np.full((h, w), 100, dtype=np.int8)
    occ[1 : 1 + room, 1 : 1 + room] = 0
    occ[1 : 1 + other, w - 1 - other : w - 1] = 0
    top = 1 + (min(room, other) - lane) // 2
    occ[top : top + lane, 1 + room : w - 1 - other] = 0
    return planner.RobotMap(occ, planner.MapFrame((h, w), resolution, (0.0, 0.0, 0.0)))


@dataclass(frozen=True)
class Scenario:
    """Robots (start, goal cells) of one radius on one map."""

    name: str
    robot_map: planner.RobotMap
    radius: float
    robots: tuple[tuple[tuple[int, int], tuple[int, int]], ...]


def _spread(
    cells: npt.NDArray[np.int64], count: int, apart: float, rng: np.random.Generator
) -> list[tuple[int, int]]:
    """``count`` of ``cells`` (rows of ``(r, c)``) at least ``apart`` cells from each other."""
    chosen: list[tuple[int, int]] = []
    for i in rng.permutation(len(cells)):
        r, c = int(cells[i, 0]), int(cells[i, 1])
        if all((r - a) ** 2 + (c - b) ** 2 > apart * apart for a, b in chosen):
            chosen.append((r, c))
            if len(chosen) == count:
                return chosen
    raise ValueError(f"cannot place {count} robots {apart:.1f} cells apart")


def corridor_scenario(
    per_side: int, seed: int, *, resolution: float = 0.1, room_m: float = 5.0
) -> Scenario:
    """``per_side`` robots in each room of :func:`corridor_map` (a 0.8 m lane, 2 m long), each
    going to the other room."""
    m = corridor_map(resolution=resolution, room_m=room_m)
    return _swap(f"corridor x{2 * per_side}", m, CORRIDOR_RADIUS, per_side, seed)


def random_corridor_scenario(seed: int, *, radius: float = 0.25) -> Scenario:
    """Rooms of random sizes (2.5-5 m) joined by a corridor 1-4 m long and 2r + 0.05 m to 4r
    wide, 1-4 robots a side swapping rooms (as many as the rooms hold apart)."""
    rng = np.random.default_rng(seed)
    resolution = 0.025
    lane = float(rng.uniform(2 * radius + 0.05, 4 * radius))
    m = corridor_map(
        resolution=resolution, lane_m=lane, length_m=float(rng.uniform(1.0, 4.0)),
        room_m=float(rng.uniform(2.5, 5.0)), right_m=float(rng.uniform(2.5, 5.0)),
    )  # fmt: skip
    per_side = int(rng.integers(1, 5))
    while True:
        try:
            return _swap(f"rooms {seed} x{2 * per_side}", m, radius, per_side, seed)
        except ValueError:
            per_side -= 1
            if per_side == 0:
                raise


def _swap(name: str, m: planner.RobotMap, radius: float, per_side: int, seed: int) -> Scenario:
    """``per_side`` robots in each room, each going to a place in the other room; starts and
    goals apart by both radii and a margin (and a robot's diameter from the corridor)."""
    rng = np.random.default_rng(seed)
    space = planner.configuration_space(m, robot_radius=radius)
    cells = np.argwhere(space.traversable == 1)
    # The corridor's columns: those with few free cells (at most a lane's), between the rooms.
    free = (m.occupancy < 50).sum(axis=0)
    narrow = np.nonzero((free > 0) & (free <= 4 * radius / m.resolution + 2))[0]
    far = round(2 * radius / m.resolution) + 1
    left = cells[cells[:, 1] <= narrow.min() - far]
    right = cells[cells[:, 1] >= narrow.max() + far]
    apart = (2 * radius + 0.1) / m.resolution
    ls, rs = _spread(left, 2 * per_side, apart, rng), _spread(right, 2 * per_side, apart, rng)
    robots = [(ls[i], rs[per_side + i]) for i in range(per_side)]
    robots += [(rs[i], ls[per_side + i]) for i in range(per_side)]
    robots = [robots[i] for i in rng.permutation(len(robots))]
    return Scenario(name, m, radius, tuple(robots))


def random_scenario(
    robot_map: planner.RobotMap, count: int, seed: int, *, radius: float = ROS_RADIUS
) -> Scenario:
    """``count`` robots with random starts and goals on the map's largest traversable region,
    all of them far apart (more than the sum of radii and a margin)."""
    space = planner.configuration_space(robot_map, robot_radius=radius)
    region = _largest_region(space.traversable)
    rng = np.random.default_rng(seed)
    apart = (2 * radius + 0.3) / robot_map.resolution
    ends = _spread(np.argwhere(region), 2 * count, apart, rng)
    robots = tuple((ends[i], ends[count + i]) for i in range(count))
    return Scenario(f"random x{count}", robot_map, radius, robots)


def _largest_region(traversable: npt.NDArray[np.uint8]) -> npt.NDArray[np.bool_]:
    """The largest 4-connected region of traversable cells (the first of the largest)."""
    labels, count = ndimage.label(traversable.astype(bool))
    if not count:
        return np.zeros(traversable.shape, dtype=bool)
    largest = 1 + int(np.argmax(np.bincount(labels.ravel())[1:]))
    out: npt.NDArray[np.bool_] = labels == largest
    return out


def map_body(robot_map: planner.RobotMap) -> dict[str, Any]:
    """The map as a rosbridge ``nav_msgs/OccupancyGrid`` (row 0 at the origin)."""
    h, w = robot_map.shape
    ox, oy, yaw = robot_map.origin
    return {
        "occupancy_grid": {
            "info": {
                "resolution": robot_map.resolution,
                "width": w,
                "height": h,
                "origin": {
                    "position": {"x": ox, "y": oy, "z": 0.0},
                    "orientation": {"x": 0.0, "y": 0.0, "z": np.sin(yaw / 2), "w": np.cos(yaw / 2)},
                },
            },
            "data": np.flipud(robot_map.occupancy).ravel().tolist(),
        }
    }

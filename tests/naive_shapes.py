"""Slow, obvious references for robot shapes: whether a footprint at a pose holds a blocked
cell's center (shapely's exact point-in-polygon over every blocked cell near it), the same
along a motion checked every centimeter and two degrees, a path's curvature, and a trapezoid
speed profile's time computed segment by segment in closed form."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely
from scipy.spatial import cKDTree
from shapely import affinity

import planner


def blocked_centers(robot_map: planner.RobotMap, unknown: str = "blocked") -> np.ndarray:
    """``(n, 2)`` map-frame centers of the map's blocked cells."""
    occ = robot_map.occupancy
    blocked = occ >= 65
    if unknown == "blocked":
        blocked |= occ < 0
    out: np.ndarray = robot_map.frame.centers(np.argwhere(blocked))
    return out


def hits(footprint: Any, centers: np.ndarray, pose: Any, tree: Any = None) -> bool:
    """Whether the footprint (vertices, robot frame) at ``pose`` ``(x, y, yaw)`` holds one of
    the ``centers`` (on its outline counts), those near found by ``tree`` (a KD-tree of them)."""
    x, y, yaw = (float(v) for v in pose)
    polygon = affinity.translate(
        affinity.rotate(shapely.Polygon(footprint), yaw, origin=(0, 0), use_radians=True), x, y
    )
    reach = max(math.hypot(*v) for v in footprint) + 1e-9
    tree = cKDTree(centers) if tree is None else tree
    near = centers[tree.query_ball_point([x, y], reach)].reshape(-1, 2)
    return bool(shapely.intersects_xy(polygon, near[:, 0], near[:, 1]).any())


def motion_hits(
    footprint: Any, centers: np.ndarray, poses: np.ndarray, step: float = 0.01, angle: float = 2.0
) -> list[int]:
    """The indices ``i`` of the poses where the footprint, moved straight from pose ``i`` to pose
    ``i + 1`` (heading turned the short way) and checked every ``step`` meters and ``angle``
    degrees, holds a blocked cell's center (``i = len - 1``: the last pose itself)."""
    bad: list[int] = []
    tree = cKDTree(centers)
    for i in range(len(poses) - 1):
        a, b = poses[i], poses[i + 1]
        turn = math.remainder(b[2] - a[2], 2 * math.pi)
        n = max(
            1, math.ceil(math.dist(a[:2], b[:2]) / step), math.ceil(abs(math.degrees(turn)) / angle)
        )
        for k in range(n):
            f = k / n
            pose = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * turn)
            if hits(footprint, centers, pose, tree):
                bad.append(i)
                break
    if hits(footprint, centers, poses[-1], tree):
        bad.append(len(poses) - 1)
    return bad


def curvatures(poses: np.ndarray) -> np.ndarray:
    """The curvature between consecutive poses that move (turns in place left out), 1/m: of the
    circle through both tangent to their headings, ``2 sin(turn / 2) / chord``."""
    d = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    turn = np.abs([math.remainder(t, 2 * math.pi) for t in np.diff(poses[:, 2])])
    moving = d > 1e-9
    out: np.ndarray = 2 * np.sin(turn[moving] / 2) / d[moving]
    return out


def trapezoid(length: float, v_max: float, a_max: float) -> float:
    """Seconds to drive ``length`` meters from rest to rest at most ``v_max``, accelerating and
    braking at ``a_max``: a trapezoid, or a triangle when it is too short to reach ``v_max``."""
    if length >= v_max * v_max / a_max:
        return length / v_max + v_max / a_max
    return 2 * math.sqrt(length / a_max)


RECTANGLE = [[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]]
"""The issue's robot: 0.6 m x 0.4 m, its reference point at the middle."""


def parking_bay(
    res: float = 0.05, length: float = 8.0
) -> tuple[planner.RobotMap, dict[str, float], dict[str, float]]:
    """The issue's parking scenario: a 2 m aisle (y 0.5 to 2.5 m, x 0 to ``length`` m) with a
    bay 0.8 m wide and 1.2 m deep off its top side (x 3.6 to 4.4 m); a start in the aisle
    facing along it, a goal in the bay facing out (toward the aisle)."""
    H, W = round(4.0 / res), round(length / res)
    grid = np.ones((H, W), dtype=np.int64)

    def free(x0: float, x1: float, y0: float, y1: float) -> None:
        grid[H - round(y1 / res) : H - round(y0 / res), round(x0 / res) : round(x1 / res)] = 0

    free(0.0, length, 0.5, 2.5)
    free(3.6, 4.4, 2.5, 3.7)
    start = {"x": 1.5, "y": 1.5, "yaw": 0.0}
    goal = {"x": 4.0, "y": 3.25, "yaw": -math.pi / 2}
    return planner.grid_map(grid.tolist(), resolution=res), start, goal

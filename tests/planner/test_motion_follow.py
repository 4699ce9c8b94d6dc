"""A footprint turning in place follows the plan's smoothed grid route where it fits: on the
shared ROS maps its routes are no longer than its enclosing circle's (the median over seeded
routes) and free by shapely's exact check; round a corner too tight for the route's poses the
hybrid search mends that stretch alone."""

from __future__ import annotations

import math
import statistics
from pathlib import Path

import numpy as np
import pytest

import planner
from planner.footprint import footprint_cells, footprint_of
from planner.motion import footprint_clearance, grid_of, motions_free
from planner.motion.hybrid import check_spacing
from tests import naive_shapes
from tests.naive_shapes import RECTANGLE

MAPS = ("depot", "tb3_sandbox", "smoothers_world")

Point = dict[str, float]


def _routes(robot_map: planner.RobotMap, count: int, seed: int) -> list[tuple[Point, Point]]:
    """Seeded start/goal points at least 4 m apart where the rectangle's enclosing circle
    stands and the rectangle keeps 0.2 m off the walls at every heading (a random yaw at the
    start)."""
    enclosing = footprint_of(RECTANGLE).circumscribed_radius
    disc = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=enclosing))
    grid = grid_of(disc)
    cells = footprint_cells(footprint_of(RECTANGLE), robot_map.resolution)
    free = np.argwhere(disc.passable() == 1)
    rng = np.random.default_rng(seed)
    yaws = np.arange(72) * math.pi / 36
    out: list[tuple[Point, Point]] = []
    while len(out) < count:
        ends = robot_map.frame.centers(free[rng.integers(len(free), size=2)])
        (sx, sy), (gx, gy) = ends
        if math.hypot(gx - sx, gy - sy) < 4.0:
            continue
        at = grid.to_grid([(x, y, yaw) for x, y in ends for yaw in yaws])
        if footprint_clearance(grid, cells, at).min() < 0.2:
            continue
        start = {"x": float(sx), "y": float(sy), "yaw": float(rng.uniform(-math.pi, math.pi))}
        out.append((start, {"x": float(gx), "y": float(gy)}))
    return out


@pytest.mark.parametrize("name", MAPS)
def test_the_rectangle_is_no_longer_than_its_enclosing_circle(ros: Path, name: str) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    enclosing = footprint_of(RECTANGLE).circumscribed_radius
    rect = planner.analyse_map(robot_map, planner.resolve_params("wide", footprint=RECTANGLE))
    disc = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=enclosing))
    centers = naive_shapes.blocked_centers(robot_map)
    ratios = []
    for start, goal in _routes(robot_map, 5, seed=11):
        try:
            circle = planner.plan(None, start, goal, analysis=disc, robot_radius=enclosing)
            circle_m = circle.length_poses_m
        except planner.PlannerError:
            continue  # not joined for the circle (the rectangle may still go)
        plan = planner.plan(None, start, goal, analysis=rect, footprint=RECTANGLE)
        assert naive_shapes.motion_hits(RECTANGLE, centers, plan.poses) == []
        assert (plan.directions == 1).all()
        ratios.append(plan.length_poses_m / circle_m)
    assert len(ratios) >= 3
    assert statistics.median(ratios) <= 1.0, ratios


def _corner(width: float, res: float = 0.05) -> planner.RobotMap:
    """A corridor ``width`` meters wide along the bottom of a 5 m square, turning up its right
    side."""
    H = W = round(5.0 / res)
    grid = np.ones((H, W), dtype=np.int64)
    grid[
        H - round((0.5 + width) / res) : H - round(0.5 / res), round(0.2 / res) : round(4 / res)
    ] = 0
    grid[H - round(4.8 / res) : H - round(0.5 / res), round((4 - width) / res) : round(4 / res)] = 0
    return planner.grid_map(grid.tolist(), resolution=res)


def test_a_corner_too_tight_for_the_routes_poses_is_mended_there_alone() -> None:
    robot_map = _corner(0.6)
    start, goal = {"x": 1.0, "y": 0.8, "yaw": 0.0}, {"x": 3.7, "y": 4.0, "yaw": math.pi / 2}
    plan = planner.plan(robot_map, start, goal, footprint=RECTANGLE)
    disc = planner.plan(robot_map, start, goal, robot_radius=0.2)  # the inscribed disc
    centers = naive_shapes.blocked_centers(robot_map)
    grid = grid_of(disc.analysis)
    cells = footprint_cells(footprint_of(RECTANGLE), robot_map.resolution)
    along = motions_free(grid, cells, grid.to_grid(disc.poses), *check_spacing(cells))
    assert not along.all()  # the table cannot clear the disc's poses round the corner
    assert naive_shapes.motion_hits(RECTANGLE, centers, plan.poses) == []
    assert plan.motion is not None
    assert plan.motion.expansions > 0  # the search mended a stretch...
    head = np.flatnonzero(np.hypot(*(disc.poses[:, :2] - [start["x"], start["y"]]).T) < 0.5)
    np.testing.assert_array_equal(plan.poses[head], disc.poses[head])  # ...not the start
    np.testing.assert_array_equal(plan.poses[-3:], disc.poses[-3:])  # ...nor the goal's end
    assert abs(math.remainder(plan.poses[-1][2] - goal["yaw"], 2 * math.pi)) < 1e-9

"""The path ahead of a stepping footprint or car (``Step.poses``): free for the footprint by
shapely's exact check (every centimeter and two degrees) among the map's blocked cells and this
step's obstacles with their margin, and within a car's turning radius; on its plan, the plan's
own poses."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import planner
from tests import naive_shapes
from tests.naive_shapes import RECTANGLE

START, GOAL = {"x": 3.0, "y": 3.0, "yaw": 0.0}, {"x": 26.0, "y": 12.0, "yaw": 1.5}


@pytest.fixture(scope="module")
def depot(ros: Path) -> planner.RobotMap:
    return planner.read_ros_map(ros / "depot.yaml")


def _centers(
    plan: planner.Plan, robot_map: planner.RobotMap, obstacles: list[list[int]]
) -> np.ndarray:
    """The map's blocked cells' centers and those of the obstacles' cells and their margin."""
    m = plan.params.dynamic_margin
    near = {
        (r + dr, c + dc)
        for r, c in obstacles
        for dr, dc in itertools.product(range(-m, m + 1), repeat=2)
    }
    extra = plan.analysis.frame.centers(np.array(sorted(near)).reshape(-1, 2))
    return np.concatenate([naive_shapes.blocked_centers(robot_map), extra])


def _check(plan: planner.Plan, step: planner.Step, centers: np.ndarray, car: bool) -> None:
    poses = np.array(step.poses)
    assert len(poses) >= 1
    assert naive_shapes.motion_hits(RECTANGLE, centers, poses) == []
    if car and len(poses) > 1:
        assert naive_shapes.curvatures(poses).max() <= 2.0 + 1e-6


@pytest.mark.parametrize("motion", ["car", "diff"])
def test_steps_on_the_plan_answer_its_own_poses(depot: planner.RobotMap, motion: str) -> None:
    radius: dict[str, Any] = {} if motion == "diff" else {"min_turning_radius": 0.5}
    plan = planner.plan(depot, START, GOAL, footprint=RECTANGLE, motion=motion, **radius)
    session = planner.Session(plan)
    centers = naive_shapes.blocked_centers(depot)
    own = {tuple(p) for p in plan.poses.round(9).tolist()}
    for _ in range(12):
        step = session.step()
        _check(plan, step, centers, motion == "car")
        assert len(step.poses) > 10  # the horizon's worth, not a stub
        assert {tuple(p) for p in np.round(step.poses[1:], 9).tolist()} <= own


@pytest.mark.parametrize("motion", ["car", "diff"])
def test_an_obstacle_ahead_is_kept_off_the_footprint(depot: planner.RobotMap, motion: str) -> None:
    radius: dict[str, Any] = {} if motion == "diff" else {"min_turning_radius": 0.5}
    plan = planner.plan(depot, START, GOAL, footprint=RECTANGLE, motion=motion, **radius)
    session = planner.Session(plan)
    first = session.step()
    # An obstacle on the plan's poses 1.2 m ahead of the robot.
    poses = plan.poses
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
    i = int(np.argmin(np.hypot(*(poses[:, :2] - first.poses[0][:2]).T)))
    x, y = poses[int(np.searchsorted(along, along[i] + 1.2)), :2]
    obstacles = [list(depot.frame.cell_of({"x": x, "y": y}))]
    step = session.step(obstacles)
    _check(plan, step, _centers(plan, depot, obstacles), motion == "car")
    assert len(step.poses) > 5  # as far as is free, not a stub
    assert math.dist(step.poses[-1][:2], (x, y)) > 0.2  # it never reaches the obstacle

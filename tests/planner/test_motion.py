"""The hybrid search on the shared ROS maps and the parking scenario: every pose and every
motion between poses free by shapely's exact check (every centimeter and two degrees), a car's
curvature within its radius, the goal's yaw met, a cusp to reverse into a bay; and the
trapezoid duration against a closed form."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import planner
from tests import naive_shapes
from tests.naive_shapes import RECTANGLE

INF = np.full(1000, np.inf)

ROUTES = [  # depot.yaml (0.05 m): points in meters, start and goal yaw
    ((3.0, 3.0, 0.0), (26.0, 12.0, 1.5)),
    ((12.0, 4.0, math.pi / 2), (6.0, 12.5, math.pi)),
    ((20.0, 3.5, math.pi), (28.0, 8.0, 0.0)),
]


def _point(p: tuple[float, float, float]) -> dict[str, float]:
    return {"x": p[0], "y": p[1], "yaw": p[2]}


@pytest.fixture(scope="module")
def depot(ros: Path) -> planner.RobotMap:
    return planner.read_ros_map(ros / "depot.yaml")


def _check(plan: planner.Plan, robot_map: planner.RobotMap, goal: dict[str, float]) -> None:
    poses = plan.poses
    centers = naive_shapes.blocked_centers(robot_map)
    assert naive_shapes.motion_hits(RECTANGLE, centers, poses) == []
    assert math.dist(poses[-1][:2], (goal["x"], goal["y"])) < 1e-9
    assert abs(math.remainder(poses[-1][2] - goal["yaw"], 2 * math.pi)) <= math.radians(2)
    steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    assert steps.max() <= robot_map.resolution + 1e-9
    assert set(plan.directions.tolist()) <= {1, -1}
    assert len(plan.directions) == len(poses)


@pytest.mark.parametrize("route", ROUTES)
@pytest.mark.parametrize("motion", ["car", "car_reverse", "diff"])
def test_depot_routes_are_free_and_keep_the_radius(
    depot: planner.RobotMap, route: tuple[tuple[float, ...], ...], motion: str
) -> None:
    start, goal = _point(route[0]), _point(route[1])  # type: ignore[arg-type]
    radius: dict[str, Any] = {} if motion == "diff" else {"min_turning_radius": 0.5}
    plan = planner.plan(depot, start, goal, footprint=RECTANGLE, motion=motion, **radius)
    _check(plan, depot, goal)
    if motion != "diff":
        assert naive_shapes.curvatures(plan.poses).max() <= 2.0 + 1e-6
    if motion != "car_reverse":
        assert (plan.directions == 1).all()


def test_a_car_reverses_into_a_bay_with_a_cusp() -> None:
    bay, start, goal = naive_shapes.parking_bay()
    plan = planner.plan(
        bay, start, goal, footprint=RECTANGLE, motion="car_reverse", min_turning_radius=0.5
    )
    _check(plan, bay, goal)
    assert plan.motion is not None
    assert plan.motion.cusps >= 1
    assert plan.directions[-1] == -1  # it backs in, to leave facing out
    assert naive_shapes.curvatures(plan.poses).max() <= 2.0 + 1e-6
    forward = planner.plan(
        bay, start, goal, footprint=RECTANGLE, motion="car", min_turning_radius=0.5
    )
    with pytest.raises(planner.NoValidPath):  # forward only, it cannot end facing out
        forward.poses  # noqa: B018


def test_a_search_out_of_time_ends_then_and_says_so() -> None:
    """Forward only, no way ends in the bay facing out: along a 24 m aisle the search would
    take about a minute to find none; given 0.3 s, it stops then."""
    bay, start, goal = naive_shapes.parking_bay(length=24.0)
    car: dict[str, Any] = {"footprint": RECTANGLE, "motion": "car", "min_turning_radius": 0.5}
    ahead = {"x": 3.0, "y": 1.5, "yaw": 0.0}
    planner.plan(bay, start, ahead, **car).poses  # noqa: B018 - the kernels compiled first
    plan = planner.plan(bay, start, goal, search_seconds=0.3, **car)
    t0 = time.perf_counter()
    with pytest.raises(planner.NoValidPath, match=r"ran out of its 0\.3 s"):
        plan.poses  # noqa: B018
    assert time.perf_counter() - t0 < 3.0  # not a speed target: the clock's bound, loosely


@pytest.mark.parametrize(
    ("overrides", "goal", "field"),
    [
        ({"motion": "car", "min_turning_radius": 0.5}, {"x": 20.0, "y": 8.0}, "goal"),
        ({"motion": "car"}, {"x": 20.0, "y": 8.0, "yaw": 0.0}, "min_turning_radius"),
        ({"motion": "car", "min_turning_radius": 0.0}, {"x": 20.0, "y": 8.0, "yaw": 0.0},
         "min_turning_radius"),
        ({"motion": "boat"}, {"x": 20.0, "y": 8.0, "yaw": 0.0}, "motion"),
    ],
)  # fmt: skip
def test_bad_motions_name_their_field(
    depot: planner.RobotMap, overrides: dict[str, Any], goal: dict[str, float], field: str
) -> None:
    with pytest.raises(planner.InvalidInput) as info:
        planner.plan(depot, {"x": 3.0, "y": 3.0}, goal, footprint=RECTANGLE, **overrides)
    assert info.value.field == field


def test_a_footprint_that_does_not_fit_at_the_start_is_start_occupied() -> None:
    bay, _, goal = naive_shapes.parking_bay()
    long = [[0.6, 0.2], [-0.6, 0.2], [-0.6, -0.2], [0.6, -0.2]]
    plan = planner.plan(bay, {"x": 4.0, "y": 3.4, "yaw": 0.0}, goal, footprint=long)
    with pytest.raises(planner.InvalidInput) as info:  # across the bay: too long
        plan.poses  # noqa: B018
    assert info.value.code == "START_OCCUPIED"


def test_duration_follows_an_independent_trapezoid() -> None:
    # A straight 6 m, a turn in place of 90 degrees, 0.5 m more: two trapezoids and the turn.
    first = np.stack([np.linspace(0, 6, 121), np.zeros(121), np.zeros(121)], axis=1)
    second = np.stack([np.full(11, 6.0), np.linspace(0, 0.5, 11), np.full(11, math.pi / 2)], 1)
    poses = np.concatenate([first, second])
    n = len(poses)
    got = planner.profile_time(poses, np.ones(n, np.int8), INF[:n], max_velocity=1.0,
                               max_acceleration=0.5, max_angular_velocity=0.5)  # fmt: skip
    want = naive_shapes.trapezoid(6.0, 1.0, 0.5) + (math.pi / 2) / 0.5
    want += naive_shapes.trapezoid(0.5, 1.0, 0.5)
    assert got == pytest.approx(want, rel=0.05)
    # Forward 3 m then back 2 m: stopped at the cusp.
    line = np.stack([np.concatenate([np.linspace(0, 3, 61), np.linspace(2.95, 1, 40)]),
                     np.zeros(101), np.zeros(101)], axis=1)  # fmt: skip
    direction = np.array([1] * 61 + [-1] * 40, np.int8)
    got = planner.profile_time(line, direction, INF[:101], max_velocity=1.0, max_acceleration=0.5)
    want = naive_shapes.trapezoid(3.0, 1.0, 0.5) + naive_shapes.trapezoid(2.0, 1.0, 0.5)
    assert got == pytest.approx(want, rel=0.05)
    # A circle of 0.5 m at 0.4 rad/s: at most 0.2 m/s on it.
    a = np.linspace(0, 2 * math.pi, 400)
    circle = np.stack([0.5 * np.sin(a), 0.5 - 0.5 * np.cos(a), a], axis=1)
    got = planner.profile_time(circle, np.ones(400, np.int8), INF[:400], max_velocity=1.0,
                                max_acceleration=0.5, max_angular_velocity=0.4)  # fmt: skip
    assert got == pytest.approx(naive_shapes.trapezoid(math.pi, 0.2, 0.5), rel=0.05)


def test_a_plans_duration_uses_the_profile(depot: planner.RobotMap) -> None:
    start, goal = {"x": 3.0, "y": 3.0, "yaw": 0.0}, {"x": 8.0, "y": 3.0, "yaw": 0.0}
    plan = planner.plan(depot, start, goal, footprint=RECTANGLE, max_velocity=1.0,
                        max_acceleration=0.5)  # fmt: skip
    assert plan.duration_s == pytest.approx(
        naive_shapes.trapezoid(plan.length_poses_m, 1.0, 0.5), rel=0.05
    )


def test_a_route_only_the_rectangle_takes(depot: planner.RobotMap) -> None:
    """From a place along a wall where the 0.6 x 0.4 m rectangle fits but not its enclosing
    circle (0.361 m), the rectangle drives to the middle of the depot."""
    start, goal = {"x": 26.425, "y": 6.525, "yaw": 0.0}, {"x": 17.175, "y": 8.175}
    enclosing = math.hypot(0.3, 0.2)
    with pytest.raises(planner.InvalidInput) as info:
        planner.plan(depot, start, goal, robot_radius=enclosing)
    assert info.value.code == "START_OCCUPIED"
    plan = planner.plan(depot, start, goal, footprint=RECTANGLE)
    centers = naive_shapes.blocked_centers(depot)
    assert naive_shapes.motion_hits(RECTANGLE, centers, plan.poses) == []
    assert math.dist(plan.poses[-1][:2], (goal["x"], goal["y"])) < 1e-9

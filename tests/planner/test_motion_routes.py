"""Waypoints with a footprint or a car: the legs join with the heading the robot arrives with,
each pose free by shapely's exact check and within a car's radius, the directions of a car
that reverses through a waypoint kept; a car needs a yaw at every waypoint."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import planner
from tests import naive_shapes
from tests.naive_shapes import RECTANGLE

CAR = {"footprint": RECTANGLE, "motion": "car_reverse", "min_turning_radius": 0.5}


def test_a_car_backs_into_the_bay_on_its_way_and_drives_out() -> None:
    bay, start, parked = naive_shapes.parking_bay(length=10.0)
    goal = {"x": 8.0, "y": 1.5, "yaw": 0.0}
    plan = planner.plan(bay, start, goal, waypoints=[parked], **CAR)  # type: ignore[arg-type]
    poses, direction = plan.poses, plan.directions
    assert len(direction) == len(poses)
    assert naive_shapes.motion_hits(RECTANGLE, naive_shapes.blocked_centers(bay), poses) == []
    assert naive_shapes.curvatures(poses).max() <= 2.0 + 1e-6
    (w,) = plan.waypoint_indices
    assert math.dist(poses[w][:2], (parked["x"], parked["y"])) < 1e-9
    assert abs(math.remainder(poses[w][2] - parked["yaw"], 2 * math.pi)) < 1e-9
    assert direction[w] == -1  # in reverse into the bay...
    assert direction[-1] == 1  # ...and forward out of it
    assert plan.summary()["directions"] == direction.tolist()


def test_a_rectangle_goes_on_from_a_waypoint_as_it_arrived(ros: Path) -> None:
    depot = planner.read_ros_map(ros / "depot.yaml")
    start, goal = {"x": 3.0, "y": 3.0, "yaw": 0.0}, {"x": 26.0, "y": 12.0, "yaw": 1.5}
    plan = planner.plan(depot, start, goal, waypoints=[{"x": 12.0, "y": 4.0}], footprint=RECTANGLE)
    poses = plan.poses
    assert naive_shapes.motion_hits(RECTANGLE, naive_shapes.blocked_centers(depot), poses) == []
    (w,) = plan.waypoint_indices
    # The next leg starts with the heading the robot arrived with: any turn there is the leg's
    # own, checked for the footprint, and smooth (15 degrees a pose at most).
    arrived = plan.route.legs[0].poses[-1] if plan.route is not None else None
    assert arrived is not None
    assert poses[w][2] == pytest.approx(arrived[2], abs=1e-12)
    turns = np.abs(np.angle(np.exp(1j * np.diff(poses[w - 1 : w + 3, 2]))))
    assert turns.max() <= math.radians(15) + 1e-9


def test_a_car_needs_a_yaw_at_every_waypoint(ros: Path) -> None:
    depot = planner.read_ros_map(ros / "depot.yaml")
    start, goal = {"x": 3.0, "y": 3.0, "yaw": 0.0}, {"x": 26.0, "y": 12.0, "yaw": 1.5}
    with pytest.raises(planner.InvalidInput) as info:
        planner.plan(depot, start, goal, waypoints=[{"x": 12.0, "y": 4.0}], **CAR)  # type: ignore[arg-type]
    assert info.value.field == "waypoints[0]"


def test_goal_tolerance_finds_where_the_footprint_fits() -> None:
    """A goal by the aisle's wall, facing it: the rectangle does not fit there (its inscribed
    disc does); within 1 m, the nearest place it fits at that yaw."""
    bay, start, _ = naive_shapes.parking_bay()
    goal = {"x": 1.5, "y": 0.75, "yaw": -math.pi / 2}  # its front 0.05 m into the wall
    plan = planner.plan(bay, start, goal, footprint=RECTANGLE)
    with pytest.raises(planner.InvalidInput) as info:
        plan.poses  # noqa: B018
    assert info.value.code == "GOAL_OCCUPIED"
    plan = planner.plan(bay, start, goal, footprint=RECTANGLE, goal_tolerance=1.0)
    assert plan.goal_used is not None
    assert 0 < math.dist(plan.goal_used, (goal["x"], goal["y"])) <= 1.0
    poses = plan.poses
    assert naive_shapes.motion_hits(RECTANGLE, naive_shapes.blocked_centers(bay), poses) == []
    assert math.dist(poses[-1][:2], plan.goal_used) < 1e-9
    assert abs(math.remainder(poses[-1][2] - goal["yaw"], 2 * math.pi)) < 1e-9

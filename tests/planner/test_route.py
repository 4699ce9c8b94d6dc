"""Plans through waypoints: the path visits each in order, the poses hold each waypoint's point at
``waypoint_indices`` and every leg passes the brute-force checker, stepping follows the whole
route, and bad waypoints are refused naming ``waypoints[i]``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import planner
from planner import InvalidInput, NoValidPath
from tests import naive_poses
from tests.conftest import grid_from

RADIUS = 0.22

GRID = grid_from(
    """
    ................
    ..####......#...
    ..#.........#...
    ..#..###....#...
    .....#..........
    .....#....####..
    ..........#.....
    ..........#.....
    """
)


def visits_in_order(path: np.ndarray, cells: list[Any]) -> list[int]:
    """The index in ``path`` where each of ``cells`` is reached, each after the previous."""
    rows = path.tolist()
    at, out = 0, []
    for cell in cells:
        at = rows.index(list(cell), at)
        out.append(at)
    return out


def point_of(plan: planner.Plan, waypoint: Any) -> tuple[float, float]:
    if isinstance(waypoint, dict):
        return waypoint["x"], waypoint["y"]
    x, y = plan.analysis.frame.centers([waypoint])[0]
    return float(x), float(y)


def check_route(plan: planner.Plan, waypoints: list[Any]) -> None:
    """The route's path and poses, and each leg's poses by brute force."""
    assert plan.route is not None
    legs = plan.route.legs
    assert len(legs) == len(waypoints) + 1
    cells = [plan.analysis.frame.cell_of(w) if isinstance(w, dict) else tuple(w) for w in waypoints]
    assert plan.waypoints == cells
    visits_in_order(plan.path, [plan.start, *cells, plan.goal])
    assert plan.path[0].tolist() == list(plan.start)
    assert plan.path[-1].tolist() == list(plan.goal)
    steps = np.abs(np.diff(plan.path, axis=0)).max(axis=1)
    assert (steps == 1).all()  # legal moves, no cell twice in a row
    assert plan.length == pytest.approx(sum(leg.length for leg in legs))
    assert plan.arc_cost == pytest.approx(sum(leg.arc_cost for leg in legs))
    P = plan.poses
    indices = plan.waypoint_indices
    assert len(indices) == len(waypoints)
    assert indices == sorted(indices)
    for i, w in zip(indices, waypoints, strict=True):
        assert tuple(P[i, :2]) == pytest.approx(point_of(plan, w), abs=1e-12)
        if isinstance(w, dict) and w.get("yaw") is not None:
            assert abs(naive_poses.wrap(P[i, 2] - w["yaw"])) < 1e-9
    assert (np.abs(np.diff(P, axis=0)).max(axis=1) > 0).all(), "two consecutive poses alike"
    res = plan.analysis.frame.resolution
    assert (np.hypot(*np.diff(P[:, :2], axis=0).T) <= res * (1 + 1e-9)).all()
    turns = [abs(naive_poses.wrap(b - a)) for a, b in zip(P[:-1, 2], P[1:, 2], strict=True)]
    assert max(turns) <= naive_poses.MAX_TURN + 1e-9
    assert plan.length_poses_m == pytest.approx(float(np.hypot(*np.diff(P[:, :2], axis=0).T).sum()))
    # Each leg, between its waypoints' poses, keeps every rule of a plan's poses.
    a, cs = plan.analysis, plan.analysis.cspace
    bounds = [0, *indices, len(P) - 1]
    for k, leg in enumerate(legs):
        part = P[bounds[k] : bounds[k + 1] + 1]
        goal = leg.goal_used if leg.goal_used is not None else leg.goal_point
        check = naive_poses.check_poses(
            part, leg.path, a.clearance, resolution=a.frame.resolution, origin=a.frame.origin,
            robot_radius=cs.robot_radius if cs is not None else 0.0,
            start=leg.start_point, goal=goal,
            start_yaw=part[0, 2] if k else leg.start_yaw,
            goal_yaw=part[-1, 2] if k < len(legs) - 1 else leg.goal_yaw,
            outside_blocked=cs is None or cs.unknown == "blocked",
        )  # fmt: skip
        assert check.problems == [], (k, check.problems)


@pytest.mark.parametrize("preset", list(planner.PRESETS))
def test_a_route_on_a_grid_visits_its_waypoints_in_order(preset: str) -> None:
    waypoints: list[Any] = [
        [6, 1],
        {"x": 8.3, "y": 5.6},
        [0, 15],
        {"x": 13.5, "y": 1.5, "yaw": 3.0},
    ]
    p = planner.plan(GRID, [0, 0], [7, 15], preset=preset, waypoints=waypoints)
    check_route(p, waypoints)
    summary = p.summary()
    assert summary["waypoint_indices"] == p.waypoint_indices
    assert summary["waypoints"] == [list(c) for c in p.waypoints]
    assert summary["path"][0] == [0, 0]
    # The same route without waypoints is the plain plan.
    assert planner.plan(GRID, [0, 0], [7, 15], preset=preset, waypoints=[]).route is None


def test_a_route_turns_at_its_waypoints_as_their_yaws_say() -> None:
    # Back and forth: the way in and out of [0, 10] are opposite.
    there = [[0, 10]]
    p = planner.plan(GRID, [0, 0], [0, 3], preset="shortest", waypoints=there)
    check_route(p, there)
    i = p.waypoint_indices[0]
    at = np.flatnonzero((p.poses[:, 0] == p.poses[i, 0]) & (p.poses[:, 1] == p.poses[i, 1]))
    assert len(at) > 2  # a turn in place there: no way to turn round while moving through it
    # A gentle bend needs none: one pose at the waypoint.
    bend = [{"x": 7.5, "y": 7.2}]
    p = planner.plan(GRID, [0, 0], [0, 15], preset="shortest", waypoints=bend)
    check_route(p, bend)
    # With a yaw, both legs meet it there.
    facing = [{"x": 10.5, "y": 7.5, "yaw": -math.pi / 2}]
    p = planner.plan(GRID, [7, 0], [7, 15], preset="wide", waypoints=facing)
    check_route(p, facing)


def test_the_same_point_twice_and_a_waypoint_at_the_start() -> None:
    waypoints: list[Any] = [[0, 0], [4, 4], [4, 4], {"x": 4.5, "y": 3.5, "yaw": 1.0}]
    p = planner.plan(GRID, [0, 0], [7, 0], waypoints=waypoints)
    assert p.waypoints == [(0, 0), (4, 4), (4, 4), (4, 4)]
    assert (np.abs(np.diff(p.poses, axis=0)).max(axis=1) > 0).all()
    assert p.waypoint_indices[0] == 0
    assert p.poses[p.waypoint_indices[3], 2] == pytest.approx(1.0)


def test_a_route_on_a_shared_ros_map_with_a_radius(ros: Path) -> None:
    m = planner.read_ros_map(ros / "tb3_sandbox.yaml")
    cs = planner.configuration_space(m, robot_radius=RADIUS)
    cells = np.argwhere(cs.traversable == 1)
    rng = np.random.default_rng(5)
    done = 0
    fields: set[str | None] = set()
    for _ in range(40):
        picks = m.frame.centers(cells[rng.integers(len(cells), size=5)]).tolist()
        start, *middle, goal = [{"x": x, "y": y} for x, y in picks]
        middle[1]["yaw"] = 0.5
        try:
            p = planner.plan(m, start, goal, robot_radius=RADIUS, waypoints=middle)
        except NoValidPath as error:  # a waypoint in a room with no way to it
            fields.add(error.field)
            continue
        check_route(p, middle)
        done += 1
        if done == 3:
            break
    assert done == 3
    assert fields <= {"waypoints[0]", "waypoints[1]", "waypoints[2]", "goal"}


@pytest.mark.parametrize("preset", ["wide", "wfs-mmas"])
def test_stepping_follows_the_whole_route(preset: str) -> None:
    waypoints: list[Any] = [[6, 1], [0, 15], {"x": 13.5, "y": 1.5}]
    p = planner.plan(GRID, [0, 0], [7, 15], preset=preset, waypoints=waypoints)
    stored = planner.Session(p).state.as_dict()
    statuses: list[str] = []
    remaining: list[float] = []
    remaining_m: list[float] = []
    trajectory: list[tuple[int, int]] = [p.start]
    for seq in range(200):
        # As a service does: the state back from JSON-ready data every step.
        state = planner.SessionState.from_dict(stored)
        state.trajectory = list(trajectory)
        session = planner.Session(p, state)
        step = session.step([], seq=seq)
        assert session.step([], seq=seq) == step  # a retry replays, moving nothing
        stored = session.state.as_dict()
        trajectory = list(session.state.trajectory)
        statuses.append(step.status)
        assert step.remaining is not None
        assert step.remaining_m is not None
        remaining.append(step.remaining)
        remaining_m.append(step.remaining_m)
        if step.status == "arrived":
            break
    assert statuses[-1] == "arrived"
    assert set(statuses[:-1]) == {"moving"}
    assert trajectory == [tuple(c) for c in p.path.tolist()]
    visits_in_order(np.array(trajectory), [*p.waypoints, p.goal])
    assert stored["leg"] == len(waypoints)
    # remaining covers the rest of the route: at each waypoint, the legs after it.
    assert p.route is not None
    costs = p.route.costs
    for leg in range(1, len(p.waypoints) + 1):
        i = visits_in_order(np.array(trajectory), p.waypoints[:leg])[-1]
        assert remaining[i - 1] == pytest.approx(sum(costs[leg:]))
        # In meters, along the path ahead on the next leg, then the later legs' cost-to-go.
        assert remaining_m[i - 1] > sum(costs[leg + 1 :])
    assert remaining[-1] == remaining_m[-1] == 0.0
    assert max(remaining) <= sum(costs)


def test_a_reported_position_on_a_waypoint_goes_on_with_the_next_leg() -> None:
    p = planner.plan(GRID, [0, 0], [7, 15], waypoints=[[6, 1], [0, 15]])
    s = planner.Session(p)
    step = s.step([], position=[6, 1])
    assert s.state.leg == 1
    assert step.status == "moving"
    step = s.step([], position=[0, 15])
    assert s.state.leg == 2
    assert step.status == "moving"


def test_a_route_rebuilt_from_its_legs_is_the_same() -> None:
    p = planner.plan(GRID, [0, 0], [7, 15], waypoints=[[6, 1], [0, 15]])
    assert p.route is not None
    again = planner.route_of(p.route.legs, p.route.costs)
    assert again.path.tolist() == p.path.tolist()
    assert np.array_equal(again.poses, p.poses)
    assert again.waypoint_indices == p.waypoint_indices


def test_bad_waypoints_are_refused_naming_them() -> None:
    with pytest.raises(InvalidInput, match="65 waypoints") as refused:
        planner.plan(GRID, [0, 0], [7, 15], waypoints=[[0, 1]] * 65)
    assert refused.value.field == "waypoints"
    with pytest.raises(InvalidInput, match="obstacle") as refused:
        planner.plan(GRID, [0, 0], [7, 15], waypoints=[[0, 1], [1, 2]])
    assert refused.value.field == "waypoints[1]"
    with pytest.raises(InvalidInput, match="outside") as refused:
        planner.plan(GRID, [0, 0], [7, 15], waypoints=[[8, 0]])
    assert refused.value.field == "waypoints[0]"
    with pytest.raises(InvalidInput, match="outside") as refused:
        planner.plan(GRID, [0, 0], [7, 15], waypoints=[{"x": -3.0, "y": 1.0}])
    assert refused.value.field == "waypoints[0]"
    with pytest.raises(InvalidInput) as refused:
        planner.plan(GRID, [0, 0], [7, 15], waypoints=[{"x": 1.5, "y": 1.5, "yaw": math.inf}])
    assert refused.value.field == "waypoints[0].yaw"
    with pytest.raises(InvalidInput) as refused:
        planner.plan(GRID, [0, 0], [7, 15], waypoints="[0, 1]")
    assert refused.value.field == "waypoints"
    walled = grid_from(
        """
        ..#..
        ..#..
        ###..
        """
    )
    with pytest.raises(NoValidPath, match=r"waypoints\[1\] \[0, 4\] cannot be reached") as lost:
        planner.plan(walled, [0, 0], [1, 1], waypoints=[[1, 0], [0, 4]])
    assert lost.value.field == "waypoints[1]"


def test_a_waypoint_too_near_a_wall_is_waypoint_occupied() -> None:
    m = planner.grid_map(GRID, resolution=0.1)
    cs = planner.configuration_space(m, robot_radius=0.15)
    free = np.argwhere(cs.traversable == 1).tolist()
    near = np.argwhere((cs.traversable == 0) & (GRID == 0)).tolist()
    waypoints = [free[len(free) // 2], near[0]]
    with pytest.raises(InvalidInput, match="WAYPOINT_OCCUPIED") as refused:
        planner.plan(m, free[0], free[-1], robot_radius=0.15, waypoints=waypoints)
    assert (refused.value.field, refused.value.code) == ("waypoints[1]", "WAYPOINT_OCCUPIED")
    # An off-center point of a traversable cell, too near the blocked cell beside it.
    with pytest.raises(InvalidInput, match="WAYPOINT_OCCUPIED") as refused:
        planner.plan(m, [0, 0], [7, 15], waypoints=[{"x": 0.31, "y": 0.55}])
    assert (refused.value.field, refused.value.code) == ("waypoints[0]", "WAYPOINT_OCCUPIED")


@pytest.mark.parametrize("seed", range(6))
def test_routes_on_random_maps_keep_every_rule(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = (rng.random((14, 18)) < 0.18).astype(np.uint8)
    m = planner.grid_map(grid, resolution=0.05, origin=(1.0, -2.0, 0.3 * seed))
    cs = planner.configuration_space(m, robot_radius=0.04)
    cells = np.argwhere(cs.traversable == 1)
    made = 0
    codes: set[str] = set()
    for _ in range(30):
        picks = cells[rng.integers(len(cells), size=2 + int(rng.integers(1, 4)))].tolist()
        start, *middle, goal = picks
        waypoints: list[Any] = []
        for cell in middle:
            kind = rng.integers(3)
            if kind == 0:
                waypoints.append(cell)
            else:
                x, y = (m.frame.centers([cell])[0] + rng.uniform(-0.02, 0.02, size=2)).tolist()
                point: dict[str, float] = {"x": x, "y": y}
                if kind == 2:
                    point["yaw"] = float(rng.uniform(-math.pi, math.pi))
                waypoints.append(point)
        try:
            p = planner.plan(m, start, goal, robot_radius=0.04, waypoints=waypoints)
        except NoValidPath:
            continue
        except InvalidInput as error:  # an off-center point too near a wall
            codes.add(error.code)
            continue
        check_route(p, waypoints)
        made += 1
        if made == 4:
            break
    assert made >= 2
    assert codes <= {"WAYPOINT_OCCUPIED"}

"""Poses against the slow reference: every rule checked by brute force on random small maps with
random radii, frames, off-center ends and headings, and on the shared ROS maps; bad inputs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

import planner
from planner import InvalidInput
from planner.analysis.distance import squared_distances
from planner.poses import smooth_path
from tests import naive_poses
from tests.conftest import ROS_MAP_NAMES

RADIUS = 0.22


def smooth_and_check(plan: planner.Plan, **ends: object) -> naive_poses.Check:
    frame = plan.analysis.frame
    cs = plan.analysis.cspace
    kwargs = {
        "resolution": frame.resolution,
        "origin": frame.origin,
        "robot_radius": cs.robot_radius if cs is not None else 0.0,
        "outside_blocked": cs is None or cs.unknown == "blocked",
        **ends,
    }
    poses = smooth_path(plan.path, plan.analysis.clearance, **kwargs)  # type: ignore[arg-type]
    check = naive_poses.check_poses(poses, plan.path, plan.analysis.clearance, **kwargs)  # type: ignore[arg-type]
    assert check.problems == [], (check.problems, plan.path.tolist(), kwargs, poses.tolist())
    # Sharper than the rule's 2 % + one cell: the same greedy shortcut, its corners cut.
    assert check.length_m <= check.shortcut_length_m * (1 + 1e-9) + 1e-9
    return check


def point_in(frame: planner.MapFrame, cell: list[int], du: float, dv: float) -> tuple[float, float]:
    """A point of a cell, (du, dv) in [-0.5, 0.5] cells from its center along the map's axes."""
    x, y = frame.centers([cell])[0]
    yaw, res = frame.origin[2], frame.resolution
    return (
        float(x + res * (math.cos(yaw) * du - math.sin(yaw) * dv)),
        float(y + res * (math.sin(yaw) * du + math.cos(yaw) * dv)),
    )


yaws = st.one_of(st.none(), st.floats(-10.0, 10.0))
offsets = st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5))


@given(
    seed=st.integers(0, 2**32 - 1),
    size=st.tuples(st.integers(4, 24), st.integers(4, 24)),
    density=st.floats(0.0, 0.35),
    radius=st.floats(0.0, 0.35),
    origin=st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-math.pi, math.pi)),
    preset=st.sampled_from(["wide", "shortest"]),
    unknown=st.sampled_from(["blocked", "free"]),
    start_off=offsets,
    goal_off=offsets,
    start_yaw=yaws,
    goal_yaw=yaws,
)
def test_poses_meet_every_rule_on_random_maps(
    seed: int,
    size: tuple[int, int],
    density: float,
    radius: float,
    origin: tuple[float, float, float],
    preset: str,
    unknown: str,
    start_off: tuple[float, float],
    goal_off: tuple[float, float],
    start_yaw: float | None,
    goal_yaw: float | None,
) -> None:
    rng = np.random.default_rng(seed)
    grid = (rng.random(size) < density).astype(np.int8)
    robot_map = planner.grid_map(grid, resolution=0.1, origin=origin)
    params = planner.resolve_params(preset, robot_radius=radius, unknown=unknown)
    analysis = planner.analyse_map(robot_map, params)
    cells = np.argwhere(analysis.passable() == 1)
    if len(cells) < 2:
        return
    s, g = cells[rng.choice(len(cells), size=2, replace=False)]
    try:
        plan = planner.plan(
            robot_map, s.tolist(), g.tolist(), analysis=analysis, preset=preset,
            robot_radius=radius, unknown=unknown,
        )  # fmt: skip
    except planner.NoValidPath:
        return
    start = point_in(robot_map.frame, s.tolist(), *start_off)
    goal = point_in(robot_map.frame, g.tolist(), *goal_off)
    ends = {"start": start, "goal": goal, "start_yaw": start_yaw, "goal_yaw": goal_yaw}
    T = naive_poses.threshold(plan.min_clearance, radius / 0.1)
    blocked_way = [
        not naive_poses.segment_clear_to_start(
            plan.analysis.clearance,
            point,
            robot_map.frame.centers([cell])[0],
            resolution=0.1,
            origin=origin,
            threshold2=T,
            outside_blocked=unknown == "blocked",
        )
        for point, cell in ((start, s), (goal, g))
    ]
    if not any(blocked_way):
        smooth_and_check(plan, **ends)
        return
    # Only when the robot cannot go straight from its point to its cell's center.
    name = "start" if blocked_way[0] else "goal"
    with pytest.raises(InvalidInput, match=f"{name.upper()}_OCCUPIED") as info:
        smooth_and_check(plan, **ends)
    assert info.value.field == name


@given(seed=st.integers(0, 2**32 - 1), preset=st.sampled_from(list(planner.PRESETS)))
@example(seed=4132800011, preset="wfs-mmas")  # the paper's decision doubles back: loops cut
def test_poses_on_plain_grids_in_one_meter_cells(seed: int, preset: str) -> None:
    rng = np.random.default_rng(seed)
    grid = (rng.random((16, 20)) < 0.25).astype(np.uint8)
    free = np.argwhere(grid == 0)
    s, g = free[rng.choice(len(free), size=2, replace=False)]
    try:
        plan = planner.plan(grid, s.tolist(), g.tolist(), preset=preset)
    except (planner.NoValidPath, InvalidInput):
        return
    check = smooth_and_check(plan)
    assert check.length_m <= plan.length_m + 1e-9


@pytest.mark.parametrize("name", ROS_MAP_NAMES)
def test_poses_on_the_ros_maps(ros: Path, name: str) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    radius = RADIUS if robot_map.resolution <= 0.05 else 2.0 * robot_map.resolution / 3
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=radius))
    cells = np.argwhere(analysis.passable() == 1)
    rng = np.random.default_rng(sum(map(ord, name)))
    span = max(np.ptp(cells[:, 0]), np.ptp(cells[:, 1]))
    done = 0
    for _ in range(200):
        s, g = cells[rng.integers(len(cells), size=2)]
        if math.hypot(*(s - g)) < span / 3:
            continue
        try:
            plan = planner.plan(  # the wide route, as wide as it goes (no bound on detours)
                robot_map, s.tolist(), g.tolist(), analysis=analysis, robot_radius=radius,
                max_detour=100.0,
            )  # fmt: skip
        except planner.NoValidPath:
            continue
        goal_yaw = float(rng.uniform(-math.pi, math.pi))
        check = smooth_and_check(plan, goal_yaw=goal_yaw)
        assert check.length_m <= plan.length_m + 1e-9
        if check.grid_turning > 0:
            assert check.turning / check.length_m < check.grid_turning / check.grid_length_m
        done += 1
        if done == 3:
            break
    assert done == 3


def test_a_straight_path_is_one_line_at_one_heading() -> None:
    robot_map = planner.grid_map(np.zeros((3, 9), dtype=np.int8), resolution=0.5)
    plan = planner.plan(robot_map, [1, 0], [1, 8], unknown="free")
    poses = smooth_path(plan.path, plan.analysis.clearance, resolution=0.5)
    assert poses[:, 1].tolist() == [0.75] * len(poses)
    assert poses[:, 2].tolist() == [0.0] * len(poses)
    assert np.diff(poses[:, 0]).max() <= 0.5
    assert poses[0, 0] == 0.25
    assert poses[-1, 0] == 4.25


def test_turns_in_place_at_the_ends_only() -> None:
    robot_map = planner.grid_map(np.zeros((5, 5), dtype=np.int8), resolution=0.1)
    plan = planner.plan(robot_map, [2, 0], [2, 4], unknown="free")
    args = {"resolution": 0.1, "start_yaw": math.pi, "goal_yaw": math.pi / 2}
    poses = smooth_path(plan.path, plan.analysis.clearance, **args)  # type: ignore[arg-type]
    assert poses[0, 2] == pytest.approx(math.pi)
    assert poses[-1, 2] == pytest.approx(math.pi / 2)
    at_start = (poses[:, :2] == poses[0, :2]).all(axis=1)
    at_goal = (poses[:, :2] == poses[-1, :2]).all(axis=1)
    assert at_start.sum() == 14  # 180 degrees in 13 steps under 15
    assert at_goal.sum() == 8  # 90 degrees in 7
    turns = np.abs(np.angle(np.exp(1j * np.diff(poses[:, 2]))))
    assert turns.max() <= math.radians(15)
    # One cell: the turn in place from the start's yaw to the goal's.
    one = smooth_path([[2, 2]], plan.analysis.clearance, resolution=0.1, start_yaw=0, goal_yaw=1)
    assert one[:, 2].tolist() == pytest.approx(np.linspace(0, 1, 5).tolist())
    assert len(smooth_path([[2, 2]], plan.analysis.clearance)) == 1


def test_corners_are_rounded_and_the_wall_kept() -> None:
    grid = np.zeros((30, 30), dtype=np.int8)
    grid[:20, 10:12] = 1  # a wall to go around
    robot_map = planner.grid_map(grid, resolution=0.05)
    plan = planner.plan(  # the wide route round the wall, wide even if long
        robot_map, [2, 2], [2, 27], robot_radius=0.1, unknown="free", max_detour=100.0
    )
    check = smooth_and_check(plan)
    assert check.length_m < plan.length_m
    assert check.min_clearance_m > 0.1
    assert check.turning / check.length_m < 0.6 * check.grid_turning / check.grid_length_m


def test_bad_inputs_are_named() -> None:
    free = np.ones((4, 4), dtype=bool)
    free[0, 0] = False
    D = np.sqrt(squared_distances(free, outside_blocked=True)).astype(np.float32)
    cases: list[tuple[dict[str, object], str, str]] = [
        ({"path": [[1, 1, 1]]}, "path", "shape"),
        ({"path": []}, "path", "n >= 1"),
        ({"path": [[1.5, 1]]}, "path", "whole cells"),
        ({"path": [[1, 1], [9, 1]]}, "path", "outside the 4 x 4 map"),
        ({"path": [[1, 1], [3, 3]]}, "path", "8 neighbouring"),
        ({"path": [[0, 0], [1, 1]]}, "path", "is blocked"),
        ({"path": [[0, 1], [1, 1]], "robot_radius": 1.0}, "path", "not clear"),
        ({"distance": np.zeros(4)}, "distance", "2-D"),
        ({"resolution": 0}, "resolution", "> 0"),
        ({"resolution": float("nan")}, "resolution", "number"),
        ({"origin": (0, 0)}, "origin", "(x, y, yaw)"),
        ({"robot_radius": -1}, "robot_radius", ">= 0"),
        ({"robot_radius": True}, "robot_radius", "number"),
        ({"start": (9.0, 1.0)}, "start", "outside"),
        ({"start": {"x": 1}}, "start", "'x' and 'y'"),
        # The one point parser (planner.parsing.point): no unknown key, no far coordinate.
        ({"start": {"x": 1.5, "y": 1.5, "z": 0}}, "start", "no other key"),
        ({"goal": {"x": 1e12, "y": 1.5}}, "goal", "at most 1e.09"),
        ({"goal": "here"}, "goal", "point"),
        ({"goal_yaw": float("inf")}, "goal_yaw", "finite"),
        ({"start": (0.6, 3.4)}, "start", "START_OCCUPIED"),
    ]
    for change, name, text in cases:
        args: dict[str, object] = {"path": [[1, 1], [2, 2]], "distance": D, **change}
        with pytest.raises(
            InvalidInput, match=text.replace("(", r"\(").replace(")", r"\)")
        ) as info:
            smooth_path(args.pop("path"), args.pop("distance"), **args)  # type: ignore[arg-type]
        assert info.value.field == name, (change, info.value)


@given(yaw=st.floats(-math.pi, math.pi), x=st.floats(-50, 50), y=st.floats(-50, 50))
def test_a_rotated_frame_rotates_the_poses(yaw: float, x: float, y: float) -> None:
    grid = np.zeros((12, 16), dtype=np.int8)
    grid[3:9, 6:9] = 1
    robot_map = planner.grid_map(grid, resolution=0.1)
    plan = planner.plan(robot_map, [10, 1], [1, 14], robot_radius=0.12, unknown="free")
    args = {"resolution": 0.1, "robot_radius": 0.12, "outside_blocked": False}
    flat = smooth_path(plan.path, plan.analysis.clearance, **args)  # type: ignore[arg-type]
    turned = smooth_path(plan.path, plan.analysis.clearance, origin=(x, y, yaw), **args)  # type: ignore[arg-type]
    cos, sin = math.cos(yaw), math.sin(yaw)
    want_x = x + cos * flat[:, 0] - sin * flat[:, 1]
    want_y = y + sin * flat[:, 0] + cos * flat[:, 1]
    np.testing.assert_allclose(turned[:, 0], want_x, atol=1e-9)
    np.testing.assert_allclose(turned[:, 1], want_y, atol=1e-9)
    turn = np.angle(np.exp(1j * (turned[:, 2] - flat[:, 2] - yaw)))
    np.testing.assert_allclose(turn, 0.0, atol=1e-9)
    # Each yaw is the direction of travel, by atan2 of the steps around it.
    steps = np.diff(flat[:, :2], axis=0)
    heading = np.arctan2(steps[:, 1], steps[:, 0])
    between = np.abs(np.angle(np.exp(1j * (heading - flat[:-1, 2]))))
    assert between.max() <= math.radians(7.5) + 1e-9


def test_a_path_that_doubles_back_is_smoothed_without_its_loop() -> None:
    grid = np.zeros((5, 8), dtype=np.uint8)
    analysis = planner.analyse(grid, seal_tunnels=False)
    there_and_back = [[2, 1], [2, 2], [2, 3], [1, 3], [2, 3], [2, 4], [2, 5], [2, 6]]
    poses = planner.smooth_path(there_and_back, analysis.clearance)
    assert poses[:, 1].max() - poses[:, 1].min() < 1e-9  # straight along row 2: no detour
    assert math.isclose(float(np.hypot(*np.diff(poses[:, :2], axis=0).T).sum()), 5.0)

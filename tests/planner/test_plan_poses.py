"""``Plan.poses``: every preset on plain grids and the shared ROS maps, headings in, off-center
ends refused, ``goal_tolerance``, and bad yaws and tolerances."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import planner
from planner import InvalidInput
from tests import naive_poses
from tests.conftest import ROS_MAP_NAMES, grid_from

RADIUS = 0.22


def xy(point: Any) -> tuple[float, float] | None:
    return None if point is None else (float(point[0]), float(point[1]))


def check_plan(plan: planner.Plan) -> naive_poses.Check:
    """The plan's poses against every rule, by brute force."""
    a = plan.analysis
    cs = a.cspace
    goal = plan.goal_used if plan.goal_used is not None else plan.goal_point
    check = naive_poses.check_poses(
        plan.poses,
        plan.path,
        a.clearance,
        resolution=a.frame.resolution,
        origin=a.frame.origin,
        robot_radius=cs.robot_radius if cs is not None else 0.0,
        start=xy(plan.start_point),
        goal=xy(goal),
        start_yaw=plan.start_yaw,
        goal_yaw=plan.goal_yaw,
        outside_blocked=cs is None or cs.unknown == "blocked",
    )
    assert check.problems == [], (check.problems, plan.path.tolist())
    assert math.isclose(plan.length_poses_m, check.length_m, rel_tol=1e-12, abs_tol=1e-12)
    return check


GRID = grid_from(
    """
    ..........
    ..####....
    ..#.......
    ..#..###..
    .....#....
    .....#....
    """
)


@pytest.mark.parametrize("preset", list(planner.PRESETS))
def test_every_preset_on_a_plain_grid(preset: str) -> None:
    plan = planner.plan(GRID, [5, 0], [0, 9], preset=preset)
    check_plan(plan)
    assert plan.start_point == (0.5, 0.5)
    assert plan.goal_point == (9.5, 5.5)
    assert plan.poses[0, :2].tolist() == [0.5, 0.5]
    assert plan.length_poses_m <= plan.length_m + 1e-9
    summary = plan.summary()
    assert summary["poses"] == plan.poses.tolist()
    assert summary["length_poses_m"] == round(plan.length_poses_m, 6)
    assert (summary["goal_used"], summary["goal_offset_m"]) == (None, 0.0)


@pytest.mark.parametrize("preset", list(planner.PRESETS))
@pytest.mark.parametrize("name", ROS_MAP_NAMES)
def test_every_preset_on_the_ros_maps(ros: Path, name: str, preset: str) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    radius = RADIUS if robot_map.resolution <= 0.05 else 2.0 * robot_map.resolution / 3
    params = planner.resolve_params(preset, robot_radius=radius)
    analysis = planner.analyse_map(robot_map, params)
    cells = np.argwhere(analysis.passable() == 1)
    rng = np.random.default_rng(sum(map(ord, name + preset)))
    span = max(np.ptp(cells[:, 0]), np.ptp(cells[:, 1]))
    for _ in range(200):
        s, g = cells[rng.integers(len(cells), size=2)]
        if math.hypot(*(s - g)) < span / 3:
            continue
        start, goal = robot_map.frame.centers([s, g])
        yaws = rng.uniform(-math.pi, math.pi, size=2)
        try:
            plan = planner.plan(
                robot_map,
                {"x": float(start[0]), "y": float(start[1]), "yaw": float(yaws[0])},
                {"x": float(goal[0]), "y": float(goal[1]), "yaw": float(yaws[1])},
                analysis=analysis, preset=preset, robot_radius=radius,
            )  # fmt: skip
        except planner.NoValidPath:
            continue
        check_plan(plan)
        assert plan.poses[-1, 2] == pytest.approx(yaws[1], abs=1e-9)
        assert plan.poses[0, 2] == pytest.approx(yaws[0], abs=1e-9)
        return
    pytest.fail("no far-apart pair was reachable")


def test_yaw_in_is_the_last_poses_yaw_and_off_center_points_are_kept() -> None:
    robot_map = planner.grid_map(GRID, resolution=0.1, origin=(1.0, -2.0, 0.3))
    frame = robot_map.frame
    (sx, sy), (gx, gy) = frame.centers([[5, 0], [0, 9]])
    start = {"x": float(sx) + 0.02, "y": float(sy) - 0.01}
    goal = {"x": float(gx) - 0.015, "y": float(gy) + 0.01, "yaw": 2.5}
    plan = planner.plan(robot_map, start, goal, robot_radius=0.05)
    check_plan(plan)
    assert plan.goal_yaw == 2.5
    assert plan.start_yaw is None
    assert plan.poses[-1].tolist() == [goal["x"], goal["y"], 2.5]
    assert plan.poses[0, :2].tolist() == [start["x"], start["y"]]


def test_an_off_center_point_too_near_a_wall_is_refused_naming_it() -> None:
    robot_map = planner.grid_map(grid_from("....\n....\n.#..\n...."), resolution=1.0)
    # Cell [1, 1] is traversable (its center 1 m from the wall's), its corner near the wall is not.
    goal = {"x": 1.2, "y": 2.1}
    with pytest.raises(InvalidInput, match=r"GOAL_OCCUPIED: goal .*clearance is 0\.6708 m") as e:
        planner.plan(robot_map, [0, 3], goal, robot_radius=0.95, unknown="free")
    assert (e.value.field, e.value.code) == ("goal", "GOAL_OCCUPIED")
    with pytest.raises(InvalidInput, match="START_OCCUPIED") as e:
        planner.plan(robot_map, goal, [0, 3], robot_radius=0.95, unknown="free")
    assert (e.value.field, e.value.code) == ("start", "START_OCCUPIED")
    # Within a goal tolerance the cell's center is used instead.
    plan = planner.plan(
        robot_map, [0, 3], goal, robot_radius=0.95, unknown="free", goal_tolerance=0.6
    )
    assert plan.goal == (1, 1)
    assert plan.goal_used == (1.5, 2.5)
    assert plan.goal_offset_m == pytest.approx(0.5)
    check_plan(plan)


WALLED = grid_from(
    """
    ..........
    ..........
    ....####..
    ....####..
    ..........
    """
)


def test_a_start_in_unknown_space_is_called_unknown() -> None:
    grid = np.zeros((6, 8), dtype=np.int8)
    grid[:, 5:] = -1
    robot_map = planner.grid_map(grid, resolution=0.1)
    with pytest.raises(InvalidInput) as e:
        planner.plan(robot_map, [2, 6], [2, 1])
    assert e.value.code == "START_OCCUPIED"
    assert "is in unknown space" in str(e.value)
    assert "`unknown: free`" in str(e.value)
    assert "the nearest free cell is [2, 4]" in str(e.value)


def test_goal_tolerance_inside_a_wall() -> None:
    robot_map = planner.grid_map(WALLED, resolution=0.1)
    inside = {"x": 0.55, "y": 0.25, "yaw": -1.0}  # cell [2, 5]: in the wall, 0.1 m from its edge
    for tolerance in (0.0, 0.05):
        with pytest.raises(InvalidInput, match="on an obstacle") as e:
            planner.plan(robot_map, [0, 0], inside, unknown="free", goal_tolerance=tolerance)
        assert e.value.field == "goal"
        assert e.value.code == "GOAL_OCCUPIED"  # the same with a tolerance too short
        assert "the nearest free cell is [1, 5]" in str(e.value)
        assert "a goal_tolerance of 0.101 m would take it" in str(e.value)
    plan = planner.plan(robot_map, [0, 0], inside, unknown="free", goal_tolerance=0.15)
    # The nearest traversable cells: [1, 5] and [4, 5]'s centers are 0.1 m and 0.2 m away.
    assert plan.goal == (1, 5)
    assert plan.goal_used == pytest.approx((0.55, 0.35))
    assert plan.goal_offset_m == pytest.approx(0.1)
    assert plan.goal_point == (0.55, 0.25)
    check_plan(plan)
    assert plan.poses[-1, :2] == pytest.approx([0.55, 0.35])
    assert plan.poses[-1, 2] == pytest.approx(-1.0)
    summary = plan.summary()
    assert summary["goal_used"] == pytest.approx([0.55, 0.35])
    assert summary["goal_offset_m"] == pytest.approx(0.1)


def test_goal_tolerance_with_an_unreachable_goal() -> None:
    grid = grid_from("...#...\n...#...\n...#...")
    # Goal [1, 5] lies beyond a wall; the nearest reachable cell is [1, 2], 3 m away.
    with pytest.raises(planner.NoValidPath) as e:
        planner.plan(grid, [1, 0], [1, 5], goal_tolerance=2.9)
    assert "within goal_tolerance 2.9 m" in e.value.message
    plan = planner.plan(grid, [1, 0], [1, 5], goal_tolerance=3.0)
    assert plan.goal == (1, 2)
    assert plan.goal_offset_m == pytest.approx(3.0)
    check_plan(plan)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"start": {"x": 0.5, "y": 0.5, "yaw": math.nan}}, "start.yaw"),
        ({"goal": {"x": 9.5, "y": 5.5, "yaw": math.inf}}, "goal.yaw"),
        ({"goal": {"x": 9.5, "y": 5.5, "yaw": "north"}}, "goal.yaw"),
        ({"goal": {"x": 9.5, "y": 5.5, "yaw": True}}, "goal.yaw"),
        ({"goal_tolerance": -0.1}, "goal_tolerance"),
        ({"goal_tolerance": math.inf}, "goal_tolerance"),
        ({"goal_tolerance": "1"}, "goal_tolerance"),
    ],
)
def test_bad_yaws_and_tolerances_name_the_field(kwargs: dict[str, Any], field: str) -> None:
    args: dict[str, Any] = {"start": [5, 0], "goal": [0, 9], **kwargs}
    with pytest.raises(InvalidInput) as e:
        planner.plan(GRID, **args)
    assert e.value.field == field
    assert field in e.value.message


def test_a_cell_cannot_carry_a_yaw() -> None:
    with pytest.raises(InvalidInput) as e:
        planner.plan(GRID, [5, 0], [0, 9, 1.0])
    assert e.value.field == "goal"


@pytest.mark.parametrize("seed", range(12))
def test_the_tolerance_search_reaches_what_a_wave_reaches(seed: int) -> None:
    """The cells a goal tolerance may take are those a wave from the start reaches (the slow
    obvious reference: a whole cost field), found by labelling the grid's pieces instead."""
    from planner.plans.ends import nearest_reachable
    from planner.plans.whole_wave import goal_wave

    rng = np.random.default_rng(seed)
    grid = (rng.random((30, 40)) < 0.3).astype(np.int8)
    robot_map = planner.grid_map(grid, resolution=0.1)
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wfs-mmas", unknown="free"))
    free = np.argwhere(analysis.state != 1)
    sr, sc = free[rng.integers(len(free))]
    start = (int(sr), int(sc))
    for _ in range(20):
        xy = (float(rng.uniform(0, 4)), float(rng.uniform(0, 3)))
        for allow in (False, True):
            got = nearest_reachable(
                analysis, start, xy, 0.6, diagonal_cost=1.4, allow_narrow=allow
            )  # fmt: skip
            # The reference: the nearest cell within 0.6 m whose cost from the start is finite.
            grids = [False, True] if analysis.sealed and allow else [False]
            ks = [goal_wave(analysis, start, diagonal_cost=1.4, narrow=n).k for n in grids]
            best = None
            for r, c in np.argwhere(analysis.state != 1):
                x, y = analysis.frame.centers([[r, c]])[0]
                d = float(np.hypot(x - xy[0], y - xy[1]))
                if d <= 0.6 * (1 + 1e-12) and any(np.isfinite(k[r, c]) for k in ks):
                    key = (d, int(r), int(c))
                    best = key if best is None or key < best else best
            if best is None or got is None:
                assert got is None
                assert best is None
                continue
            if got != (best[1], best[2]):  # a tie within rounding: the same distance
                x, y = analysis.frame.centers([list(got)])[0]
                assert float(np.hypot(x - xy[0], y - xy[1])) == pytest.approx(best[0], rel=1e-6)


def test_a_goal_tolerance_looks_at_its_disc_only() -> None:
    """What the tolerance search holds beyond the map's own labels (its grid and their labels:
    5 bytes a cell) is a few bytes a cell of the disc's square: nothing for a small disc on a
    large map, ~6 bytes a cell for one over the whole map (issue 36: per-cell coordinates took
    2.15 GB for 100 m at 0.05 m)."""
    import tracemalloc

    from planner.plans.ends import nearest_reachable

    side = 1000
    grid = np.zeros((side, side), dtype=np.int8)
    grid[250:750, 250:750] = 1  # the goal inside a block, as benchmarks/abuse_heavy.py's
    robot_map = planner.grid_map(grid, resolution=0.05)
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wfs-mmas", unknown="free"))
    labels = 5 * side * side
    for tolerance, bound, expected in ((1.0, 0.3, None), (100.0, 7.0, (249, 499))):
        tracemalloc.start()
        try:
            got = nearest_reachable(
                analysis, (0, 0), (25.0, 25.0), tolerance, diagonal_cost=1.4, allow_narrow=False
            )  # fmt: skip
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        assert got == expected
        assert peak - labels < bound * side * side, (tolerance, peak)

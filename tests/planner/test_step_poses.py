"""The path ahead of a stepping robot (``Step.poses``, ``Step.remaining_m``) against brute force:
episodes stepped from off-center points with circles ahead, every answer's poses checked by the
rules of the plan's poses, clear of every blocked cell and circle; ``poses_ahead`` on its own
against :func:`tests.naive_poses.check_poses`."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import planner
from planner import InvalidInput
from planner.poses.route_poses import poses_ahead
from tests import naive_poses
from tests.planner.test_poses import point_in

MAX_TURN = math.radians(15.0)


def enters(a: np.ndarray, b: np.ndarray, r: int, c: int, shrink: float = 1e-7) -> bool:
    """Whether segment a-b (cells, X = col, Y = -row) enters cell (r, c)'s square: Liang-Barsky
    clipping against the square shrunk by ``shrink``."""
    lo = np.array([c - 0.5 + shrink, -r - 0.5 + shrink])
    hi = np.array([c + 0.5 - shrink, -r + 0.5 - shrink])
    d = b - a
    t0, t1 = 0.0, 1.0
    for k in range(2):
        if abs(d[k]) < 1e-15:
            if not lo[k] <= a[k] <= hi[k]:
                return False
            continue
        ta, tb = (lo[k] - a[k]) / d[k], (hi[k] - a[k]) / d[k]
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return t0 <= t1


def segment_point_distance(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> float:
    d = b - a
    L2 = float(d @ d)
    t = 0.0 if L2 == 0 else min(max(float((p - a) @ d) / L2, 0.0), 1.0)
    return float(np.hypot(*(a + t * d - p)))


def blocked_cells(
    obstacles: np.ndarray, margin: int, shape: tuple[int, int]
) -> set[tuple[int, int]]:
    out = set()
    for r, c in obstacles.tolist():
        for dr, dc in itertools.product(range(-margin, margin + 1), repeat=2):
            if 0 <= r + dr < shape[0] and 0 <= c + dc < shape[1]:
                out.add((r + dr, c + dc))
    return out


def check_step_poses(
    plan: planner.Plan,
    step: planner.Step,
    obstacles: np.ndarray,
    *,
    point: tuple[float, float] | None,
    yaw: float | None,
    circles: list[dict[str, float]] = (),  # type: ignore[assignment]
) -> list[str]:
    """Every rule of a step's poses that does not need the route they follow, by brute force."""
    problems: list[str] = []
    bad = problems.append
    a = plan.analysis
    frame = a.frame
    res, origin = frame.resolution, frame.origin
    cs = a.cspace
    radius = 0.0 if cs is None else cs.robot_radius
    P = np.array(step.poses, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or not np.isfinite(P).all():
        return [f"poses are not an (m, 3) array of finite numbers: {P.shape}"]
    start = np.array(point) if point is not None else frame.centers([step.position])[0]
    if np.abs(P[0, :2] - start).max() > 1e-9 * max(1.0, float(np.abs(start).max())):
        bad(f"first pose {P[0].tolist()} is not the start {start.tolist()}")
    if yaw is not None and abs(naive_poses.wrap(P[0, 2] - yaw)) > 1e-9:
        bad(f"first yaw {P[0, 2]} is not the robot's {yaw}")
    steps = np.hypot(*np.diff(P[:, :2], axis=0).T)
    if (steps > res * (1 + 1e-9)).any():
        bad(f"poses {steps.max():.6g} m apart, more than {res:g}")
    turns = np.array([naive_poses.wrap(q - p) for p, q in itertools.pairwise(P[:, 2])])
    if len(turns) and np.abs(turns).max() > MAX_TURN + 1e-9:
        bad(f"heading turns {math.degrees(np.abs(turns).max()):.3f} degrees in one step")
    X = naive_poses.to_cells(P[:, :2], a.shape, res, origin)
    moving = steps > 1e-9 * res
    for i in np.flatnonzero(moving):
        d = X[i + 1] - X[i]
        direction = math.atan2(d[1], d[0]) + origin[2]
        off = abs(naive_poses.wrap(direction - P[i, 2])) + abs(
            naive_poses.wrap(P[i + 1, 2] - direction)
        )
        if off > abs(turns[i]) + 1e-6 + 1e-14 * max(1.0, float(np.abs(X).max())) / math.hypot(*d):
            bad(f"step {i} goes at {direction:.6f} rad, not between its poses' yaws")
            break
    # Static clearance: more than the radius, and outside every blocked cell's square.
    blocked = naive_poses.Blocked(a.clearance, cs is None or cs.unknown == "blocked")
    R = radius / res
    need = max(R * R, naive_poses.SQUARE)
    pairs = [(X[i], X[i + 1]) for i in range(len(X) - 1)] or [(X[0], X[0])]
    # A robot too near a wall at its point goes straight back to its cell's center first.
    first = step.previous if point is not None else step.position
    center = naive_poses.to_cells(frame.centers([first]), a.shape, res, origin)[0]
    pushed = point is not None and not blocked.segment_d2(X[0], center) > need
    for j, (p, q) in enumerate(pairs):
        if pushed and np.array_equal(p, X[0]):
            continue
        if not blocked.segment_d2(p, q) > need * (1 - 1e-9):
            bad(f"segment {j} comes within the radius of a blocked cell")
            break
    # Dynamic obstacles: no blocked cell entered (beside the robot's cells of this step).
    mine = {tuple(step.previous), tuple(step.position)}
    for r, c in blocked_cells(obstacles, plan.params.dynamic_margin, a.shape) - mine:
        if any(enters(p, q, r, c) for p, q in pairs):
            bad(f"the poses enter blocked cell {[r, c]}")
            break
    for circle in circles:
        center = np.array([circle["x"], circle["y"]])
        reach = circle["radius"] + radius
        xy = P[:, :2]
        near = min(
            (segment_point_distance(xy[i], xy[i + 1], center) for i in range(len(xy) - 1)),
            default=float(np.hypot(*(xy[0] - center))),
        )
        covers = planner.circle_cells(_frame_map(frame), [circle], robot_radius=radius)
        robot_in_it = mine & blocked_cells(covers, plan.params.dynamic_margin, a.shape)
        # The cells a circle blocks cover its disc once widened by a cell: with no margin, only
        # its cells are kept clear.
        if near < reach - 1e-9 and not robot_in_it and plan.params.dynamic_margin >= 1:
            bad(f"the poses come {near:.4f} m from a circle, within its {reach:.4f} m")
    return problems


def _frame_map(frame: planner.MapFrame) -> planner.RobotMap:
    return planner.RobotMap(np.zeros(frame.shape, dtype=np.int8), frame)


def length(poses: Any) -> float:
    P = np.array(poses, dtype=np.float64)
    return float(np.hypot(*np.diff(P[:, :2], axis=0).T).sum()) if len(P) > 1 else 0.0


def episode(
    plan: planner.Plan,
    robot_map: planner.RobotMap,
    rng: np.random.Generator,
    *,
    circles_per_step: int,
    steps: int = 120,
    ahead: tuple[int, int] = (4, 16),
    radius: tuple[float, float] = (0.8, 1.6),
) -> list[planner.Step]:
    """A robot stepping along ``plan``, reporting an off-center point (and sometimes a yaw)
    each step, with circles put on the plan's path ``ahead`` of it (cells along the path), of a
    ``radius`` in cells; every answer checked."""
    frame = robot_map.frame
    res = frame.resolution
    cs = plan.analysis.cspace
    robot_radius = 0.0 if cs is None else cs.robot_radius
    session = planner.Session(plan)
    path = plan.path.tolist()
    answers = []
    for seq in range(steps):
        cell = list(session.state.position)
        du, dv = rng.uniform(-0.3, 0.3, size=2)
        point = point_in(frame, cell, float(du), float(dv))
        yaw = float(rng.uniform(-4, 4)) if rng.random() < 0.5 else None
        here = path.index(cell) if cell in path else 0
        circles = []
        for _ in range(circles_per_step):
            there = path[min(here + int(rng.integers(*ahead)), len(path) - 1)]
            if there == path[-1]:
                continue
            x, y = point_in(frame, there, *rng.uniform(-0.5, 0.5, size=2))
            circles.append({"x": x, "y": y, "radius": float(rng.uniform(*radius)) * res})
        obstacles = (
            planner.circle_cells(robot_map, circles, robot_radius=robot_radius)
            if circles
            else np.empty((0, 2), dtype=np.int64)
        )
        position: dict[str, float] = {"x": point[0], "y": point[1]}
        if yaw is not None:
            position["yaw"] = yaw
        step = session.step(obstacles.tolist(), position=position, seq=seq)
        problems = check_step_poses(plan, step, obstacles, point=point, yaw=yaw, circles=circles)
        assert problems == [], (problems, seq, point, yaw, circles, step)
        # A retry answers the very same poses.
        again = session.step(obstacles.tolist(), position=position, seq=seq)
        assert again.poses == step.poses
        assert again.remaining_m == step.remaining_m
        # At least the horizon, or to the goal, or up to where the obstacles block the way.
        goal_xy = frame.centers([plan.goal])[0]
        reaches_goal = np.allclose(step.poses[-1][:2], goal_xy, atol=1e-9)
        if length(step.poses) < plan.params.horizon_m - 1e-9 and not reaches_goal:
            end = frame.cells([step.poses[-1][:2]])[0]
            blocked = blocked_cells(obstacles, plan.params.dynamic_margin + 1, plan.analysis.shape)
            # (The paper's decision may move off the wide walk, which may then come back: the
            # poses stop before a cell they passed.)
            paper = plan.params.decision == "paper"
            assert step.move == "WAIT" or tuple(end.tolist()) in blocked or paper, step
        answers.append(step)
        if step.status in ("arrived", "blocked"):
            break
    return answers


@given(
    seed=st.integers(0, 2**32 - 1),
    radius=st.floats(0.0, 0.25),
    origin=st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-math.pi, math.pi)),
    preset=st.sampled_from(["wide", "shortest", "wfs-mmas"]),
    circles=st.integers(0, 2),
    horizon=st.sampled_from([0.3, 0.6, 2.0]),
)
def test_step_poses_from_off_center_points_with_circles_ahead(
    seed: int,
    radius: float,
    origin: tuple[float, float, float],
    preset: str,
    circles: int,
    horizon: float,
) -> None:
    rng = np.random.default_rng(seed)
    grid = (rng.random((24, 30)) < 0.12).astype(np.int8)
    robot_map = planner.grid_map(grid, resolution=0.1, origin=origin)
    params: dict[str, Any] = {"robot_radius": radius, "horizon_m": horizon}
    analysis = planner.analyse_map(robot_map, planner.resolve_params(preset, **params))
    cells = np.argwhere(analysis.passable() == 1)
    if len(cells) < 2:
        return
    s, g = cells[rng.choice(len(cells), size=2, replace=False)]
    try:
        plan = planner.plan(
            robot_map, s.tolist(), g.tolist(), analysis=analysis, preset=preset, **params
        )
    except planner.NoValidPath:
        return
    answers = episode(plan, robot_map, rng, circles_per_step=circles)
    assert answers


def test_step_poses_on_a_plain_grid_reach_the_goal_and_remaining_m_decreases() -> None:
    grid = np.zeros((12, 16), dtype=np.uint8)
    grid[3:9, 7] = 1
    plan = planner.plan(grid, [1, 1], [10, 14], horizon_m=3.0)
    session = planner.Session(plan)
    remaining = []
    for _ in range(40):
        step = session.step([])
        problems = check_step_poses(
            plan, step, np.empty((0, 2), dtype=np.int64), point=None, yaw=None
        )
        assert problems == []
        assert length(step.poses) >= 3.0 - 1e-9 or step.poses[-1][:2] == (14.5, 1.5)
        assert step.remaining_m is not None
        remaining.append(step.remaining_m)
        if step.status == "arrived":
            break
    assert step.status == "arrived"
    assert step.poses == ((14.5, 1.5, step.poses[0][2]),)
    assert remaining[-1] == 0.0
    assert all(b < a for a, b in itertools.pairwise(remaining)), remaining
    # The grid's way beyond the poses, in meters: near the plan's length at the start.
    assert remaining[0] == pytest.approx(plan.length_m - 2**0.5, rel=0.1)


def test_a_waiting_robot_gets_one_pose_where_it_is() -> None:
    plan = planner.plan(np.zeros((5, 5), dtype=np.uint8), [2, 0], [2, 4], dynamic_margin=0)
    session = planner.Session(plan)
    # Every way forward blocked (no way round): it waits, and its poses hold it where it is.
    wall = [[r, 1] for r in range(5)]
    step = session.step(wall, position={"x": 0.4, "y": 2.3, "yaw": 0.5})
    assert (step.move, step.status) == ("WAIT", "waiting")
    assert step.poses == ((0.4, 2.3, 0.5),)
    assert step.remaining_m == pytest.approx(4.0)
    assert step.blocked_at == (1.5, 2.5)  # where the way is cut: the wall's cell ahead
    # No yaw: it faces the way it will go.
    step = session.step(wall, position={"x": 0.4, "y": 2.3})
    assert step.poses == ((0.4, 2.3, 0.0),)
    # With a way round (row 0 or row 4), it goes round at once.
    step = session.step(wall[1:4], position={"x": 0.4, "y": 2.3})
    assert (step.status, step.blocked_at) == ("replanned", None)
    assert length(step.poses) >= plan.params.horizon_m


def test_the_poses_follow_the_detour_once_the_robot_replans() -> None:
    grid = np.zeros((7, 12), dtype=np.uint8)
    plan = planner.plan(grid, [3, 0], [3, 11], patience=1, dynamic_margin=0, horizon_m=20.0)
    session = planner.Session(plan)
    wall = [[r, 5] for r in range(1, 6)]
    steps = [session.step(wall) for _ in range(8)]
    assert any(s.status == "replanned" for s in steps)
    after = steps[[s.status for s in steps].index("replanned")]
    # Past the wall along the detour, to the goal.
    assert after.poses[-1][:2] == (11.5, 3.5)
    assert all(check_step_poses(plan, s, np.array(wall), point=None, yaw=None) == [] for s in steps)


def test_bad_position_yaw_is_named() -> None:
    plan = planner.plan(np.zeros((3, 3), dtype=np.uint8), [0, 0], [2, 2])
    session = planner.Session(plan)
    for yaw in (math.nan, math.inf, "north", True):
        with pytest.raises(InvalidInput, match=r"position\.yaw") as info:
            session.step([], position={"x": 0.5, "y": 2.5, "yaw": yaw})
        assert info.value.field == "position.yaw"
    assert session.state.iteration == 0


def test_sessions_without_poses_answer_none() -> None:
    plan = planner.plan(np.zeros((3, 3), dtype=np.uint8), [0, 0], [2, 2])
    step = planner.Session(plan, poses=False).step([])
    assert step.poses == ()
    assert step.remaining_m is None


@given(seed=st.integers(0, 2**32 - 1), radius=st.floats(0.0, 0.25), count=st.integers(0, 6))
def test_poses_ahead_meets_the_poses_rules_over_the_cells_it_follows(
    seed: int, radius: float, count: int
) -> None:
    rng = np.random.default_rng(seed)
    grid = (rng.random((16, 20)) < 0.15).astype(np.int8)
    robot_map = planner.grid_map(grid, resolution=0.05, origin=(1.0, -2.0, 0.3))
    params = planner.resolve_params("wide", robot_radius=radius)
    analysis = planner.analyse_map(robot_map, params)
    cells = np.argwhere(analysis.passable() == 1)
    if len(cells) < 2:
        return
    s, g = cells[rng.choice(len(cells), size=2, replace=False)]
    try:
        plan = planner.plan(
            robot_map, s.tolist(), g.tolist(), analysis=analysis, robot_radius=radius
        )
    except planner.NoValidPath:
        return
    route = np.ascontiguousarray(plan.path[: int(rng.integers(1, 40))])
    free = np.argwhere(grid == 0)
    obstacles = np.ascontiguousarray(free[rng.choice(len(free), size=count)], dtype=np.int64)
    start = point_in(robot_map.frame, route[0].tolist(), *rng.uniform(-0.25, 0.25, size=2))
    yaw = float(rng.uniform(-3, 3)) if rng.random() < 0.5 else None
    flat = np.ascontiguousarray(route[:, 0] * analysis.shape[1] + route[:, 1])
    poses, n, poses_length = poses_ahead(
        flat, analysis.clearance, obstacles.reshape(-1, 2), margin=1, exempt=0,
        resolution=0.05, origin=(1.0, -2.0, 0.3), robot_radius=radius, start=start,
        start_yaw=yaw, outside_blocked=True,
    )  # fmt: skip
    blocked = blocked_cells(obstacles, 1, analysis.shape) - {tuple(route[0].tolist())}
    # The route's cells up to the first one blocked (or a diagonal move past one).
    expected = len(route)
    for i in range(1, len(route)):
        (pr, pc), (r, c) = route[i - 1].tolist(), route[i].tolist()
        if (r, c) in blocked or (pr != r and pc != c and {(pr, c), (r, pc)} & blocked):
            expected = i
            break
    assert n == expected
    followed = route[:n]
    T = naive_poses.threshold(float(analysis.clearance[tuple(followed.T)].min()), radius / 0.05)
    if not naive_poses.segment_clear_to_start(
        analysis.clearance, start, robot_map.frame.centers([followed[0]])[0], resolution=0.05,
        origin=(1.0, -2.0, 0.3), threshold2=T,
    ):  # fmt: skip
        return  # the documented way back to the cell's center first
    assert poses_length == pytest.approx(length(poses), abs=1e-9)
    if n == 1:
        assert poses.shape == (1, 3)
        return
    check = naive_poses.check_poses(
        poses, followed, analysis.clearance, resolution=0.05, origin=(1.0, -2.0, 0.3),
        robot_radius=radius, start=start, start_yaw=yaw,
    )  # fmt: skip
    # Round blocked cells the line may have to be longer than the static shortcut.
    problems = [p for p in check.problems if not (blocked and "shortcut" in p)]
    assert problems == [], (problems, route.tolist(), obstacles.tolist())
    X = naive_poses.to_cells(poses[:, :2], analysis.shape, 0.05, (1.0, -2.0, 0.3))
    for r, c in blocked:
        assert not any(enters(X[i], X[i + 1], r, c) for i in range(len(X) - 1)), (r, c)


def test_the_poses_go_round_a_small_obstacle_as_the_next_steps_would() -> None:
    grid = np.zeros((9, 16), dtype=np.uint8)
    plan = planner.plan(grid, [0, 0], [8, 15], horizon_m=10.0, dynamic_margin=0)
    assert [2, 5] in plan.path.tolist()
    session = planner.Session(plan)
    obstacle = np.array([[2, 5]])  # on the way: the walk down the wave would stop before it
    step = session.step(obstacle.tolist())
    assert check_step_poses(plan, step, obstacle, point=None, yaw=None) == []
    assert length(step.poses) >= 10.0  # round it, not stopping
    # The steps go round it too, along the poses (within a cell and a half of their polyline:
    # the robot's cells beside their smoothed line, and back on the plan's route once clear).
    xy = np.array(step.poses)[:, :2]
    for _ in range(8):
        here = plan.analysis.frame.centers([session.step(obstacle.tolist()).position])[0]
        near = min(segment_point_distance(xy[i], xy[i + 1], here) for i in range(len(xy) - 1))
        assert near < 1.5


@pytest.mark.parametrize("name", ["depot", "tb3_sandbox"])
def test_step_poses_on_ros_maps_among_circles(ros: Path, name: str) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    params: dict[str, Any] = {"robot_radius": 0.22}
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", **params))
    cells = np.argwhere(analysis.passable() == 1)
    rng = np.random.default_rng(3)
    start = cells[rng.integers(len(cells))]
    goals = cells[rng.choice(len(cells), size=32)]
    goal = goals[np.argmax(np.abs(goals - start).sum(axis=1))]
    plan = planner.plan(robot_map, start.tolist(), goal.tolist(), analysis=analysis, **params)
    answers = episode(
        plan, robot_map, rng, circles_per_step=1, steps=60, ahead=(40, 80), radius=(2.0, 4.0)
    )
    assert len(answers) == 60
    # The horizon reached on most steps, circles on the way or not.
    assert sum(length(a.poses) >= 2.0 for a in answers) >= 30


def test_near_the_goal_the_poses_end_at_the_goal_point_with_its_yaw() -> None:
    robot_map = planner.grid_map(np.zeros((10, 14), dtype=np.uint8), resolution=0.1)
    goal = {"x": 1.23, "y": 0.27, "yaw": 2.5}
    plan = planner.plan(robot_map, [1, 1], goal, horizon_m=0.5)
    session = planner.Session(plan)
    for _ in range(30):
        step = session.step([])
        assert (
            check_step_poses(plan, step, np.empty((0, 2), dtype=np.int64), point=None, yaw=None)
            == []
        )
        if length(step.poses) < 0.5:  # the goal within the horizon: its point, its heading last
            assert step.poses[-1] == (1.23, 0.27, 2.5)
        if step.status == "arrived":
            break
    assert step.status == "arrived"

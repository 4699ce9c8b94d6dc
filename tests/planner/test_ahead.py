"""The path ahead goes around (docs/api.md, "Stepping"): a step whose route is cut within the
horizon finds the way round in that same step (the windowed detour, against a slow Dijkstra);
with no way round it waits and says where (``blocked_at``); with no obstacle nothing changes."""

from __future__ import annotations

import heapq
import math
from pathlib import Path

import numpy as np
import pytest

import planner
from planner.plans.detour import detour_cells
from planner.plans.moves import DC, DR, OPEN_PASSABLE
from tests.planner.test_step_poses import check_step_poses, length

RADIUS, CIRCLE = 0.22, 0.3


def _ros_plan(ros: Path, name: str, seed: int) -> tuple[planner.Plan, planner.RobotMap]:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=RADIUS))
    cells = np.argwhere(analysis.passable() == 1)
    rng = np.random.default_rng(seed)
    start = cells[rng.integers(len(cells))]
    goals = cells[rng.choice(len(cells), size=32)]
    goal = goals[np.argmax(np.abs(goals - start).sum(axis=1))]
    plan = planner.plan(
        robot_map, start.tolist(), goal.tolist(), analysis=analysis, robot_radius=RADIUS
    )
    return plan, robot_map


@pytest.mark.parametrize("name", ["depot", "smoothers_world"])
def test_a_circle_just_ahead_is_gone_round_in_that_same_step(ros: Path, name: str) -> None:
    plan, robot_map = _ros_plan(ros, name, 5)
    frame = robot_map.frame
    xy = frame.centers(plan.path.tolist())
    along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))
    rng = np.random.default_rng(11)
    tried = 0
    for i in range(0, len(xy) - 1, 15):
        j = int(np.searchsorted(along, along[i] + rng.uniform(0.6, 1.6)))
        if j >= len(xy) - 1:
            break
        circle = {"x": float(xy[j, 0]), "y": float(xy[j, 1]), "radius": CIRCLE}
        cells = planner.circle_cells(robot_map, [circle], robot_radius=RADIUS)
        cell = plan.path[i].tolist()
        if len(planner.detour(plan, cell, cells)) == 0:
            continue  # no way round
        tried += 1
        point = (float(xy[i, 0]), float(xy[i, 1]))
        step = planner.Session(plan).step(cells.tolist(), position={"x": point[0], "y": point[1]})
        problems = check_step_poses(plan, step, cells, point=point, yaw=None, circles=[circle])
        assert problems == [], (i, circle, problems)
        end = np.array(step.poses[-1][:2])
        to_goal = bool(np.hypot(*(end - np.array(plan.goal_point))) < 1e-6)
        assert length(step.poses) >= plan.params.horizon_m or to_goal, (i, circle)
        assert step.status == "replanned"
        assert step.blocked_at is None
        # remaining_m follows the route the poses start: no longer than the whole-map detour
        # from the robot's cell (the wide one; the grid's k from where the step's detour ends
        # is the shortest way on), no shorter than the straight line.
        assert step.remaining_m is not None
        way = np.vstack((plan.path[i], planner.detour(plan, cell, cells)))
        moves = np.abs(np.diff(way, axis=0)).sum(axis=1)
        way_m = float(np.where(moves == 2, math.sqrt(2.0), 1.0).sum()) * robot_map.resolution
        assert plan.goal_point is not None
        straight = math.dist(point, plan.goal_point)
        assert straight - 1e-9 <= step.remaining_m <= way_m + 0.1, (i, step.remaining_m, way_m)
    assert tried >= 5


def test_with_no_obstacle_the_steps_follow_the_plan_as_before(ros: Path) -> None:
    plan, _ = _ros_plan(ros, "tb3_sandbox", 2)
    with_poses, without = planner.Session(plan), planner.Session(plan, poses=False)
    for _ in range(60):
        a, b = with_poses.step([]), without.step([])
        assert (a.position, a.move, a.status, a.remaining) == (
            b.position, b.move, b.status, b.remaining,
        )  # fmt: skip
        assert a.blocked_at is None
        assert a.status in ("moving", "arrived")
    assert with_poses.state.trajectory == [tuple(c) for c in plan.path[:61].tolist()]


def test_a_corridor_blocked_for_good_waits_and_says_where() -> None:
    grid = np.ones((7, 40), dtype=np.uint8)
    grid[2:5, :] = 0  # a corridor three cells wide
    robot_map = planner.grid_map(grid, resolution=0.1)
    plan = planner.plan(robot_map, [3, 0], [3, 39], robot_radius=0.0, dynamic_margin=0)
    wall = {"x": 2.05, "y": 0.35, "radius": 0.2}  # across the corridor, 2 m ahead
    cells = planner.circle_cells(robot_map, [wall])
    session = planner.Session(plan)
    steps = [session.step(cells.tolist()) for _ in range(30)]
    assert all(s.blocked_at is not None for s in steps)
    assert all(abs(s.blocked_at[0] - 2.05) <= 0.2 + 0.1 for s in steps if s.blocked_at)
    assert steps[-1].status == "waiting"
    assert steps[-1].move == "WAIT"
    assert "replanned" not in [s.status for s in steps]
    assert not {tuple(c) for c in cells.tolist()} & set(session.state.trajectory)
    # Freed: on it goes, the way no longer cut.
    step = session.step([])
    assert step.status == "moving"
    assert step.blocked_at is None


def _slow_best(
    passable: np.ndarray,
    kw: np.ndarray,
    clean: np.ndarray,
    start: tuple[int, int],
    blocked: set[tuple[int, int]],
    within: int,
    diagonal_cost: float,
) -> float:
    """The least ``g(x) + kw(x)`` over the cells ``x`` a Dijkstra from ``start`` reaches within
    Chebyshev ``2 * within`` of it, outside ``within`` (or the goal, ``kw`` 0), whose steepest
    descent of ``kw`` enters no blocked cell before it leaves that square: what the windowed
    detour's answer costs. In float64 throughout (a float32 sum breaks the descent's ties)."""
    H, W = passable.shape
    outer = 2 * within

    def ok(r: int, c: int) -> bool:
        return 0 <= r < H and 0 <= c < W and bool(passable[r, c])

    def away(r: int, c: int) -> int:
        return max(abs(r - start[0]), abs(c - start[1]))

    def descends_clear(r: int, c: int) -> bool:
        while kw[r, c] > 0 and away(r, c) <= outer:
            best, nxt = math.inf, None
            for i in range(8):
                yr, yc = r + int(DR[i]), c + int(DC[i])
                if not ok(yr, yc):
                    continue
                a, b = i - 1, (i + 1) & 7
                beside = ok(r + int(DR[a]), c + int(DC[a])) and ok(r + int(DR[b]), c + int(DC[b]))
                if i & 1 and not beside:
                    continue
                v = (diagonal_cost if i & 1 else 1.0) + float(clean[yr, yc]) + float(kw[yr, yc])
                if kw[yr, yc] < kw[r, c] and v < best:
                    best, nxt = v, (yr, yc)
            if nxt is None:
                return True
            if nxt in blocked:
                return False
            r, c = nxt
        return True

    g = {start: 0.0}
    queue = [(0.0, start)]
    best = math.inf
    while queue:
        d, (r, c) = heapq.heappop(queue)
        if d > g[(r, c)]:
            continue
        outside = away(r, c) > within
        if kw[r, c] == 0 or (outside and descends_clear(r, c)):
            best = min(best, d + kw[r, c])
            if outside:
                continue
        free = [ok(r + int(DR[i]), c + int(DC[i])) and (r + int(DR[i]), c + int(DC[i]))
                not in blocked for i in range(8)]  # fmt: skip
        for i in range(8):
            if not free[i] or (i & 1 and not (free[i - 1] and free[(i + 1) & 7])):
                continue
            y = (r + int(DR[i]), c + int(DC[i]))
            if away(*y) > outer:
                continue
            ng = d + (diagonal_cost if i & 1 else 1.0) + float(clean[y])
            if ng < g.get(y, math.inf):
                g[y] = ng
                heapq.heappush(queue, (ng, y))
    return best


@pytest.mark.parametrize("seed", range(8))
def test_the_windowed_detour_costs_what_a_slow_dijkstra_finds(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = (rng.random((18, 26)) < 0.15).astype(np.uint8)
    grid[9, 0] = grid[9, 25] = 0
    try:
        plan = planner.plan(grid, [9, 0], [9, 25], preset="shortest", clean_weight=0.5, whole=True)
    except planner.NoValidPath:
        pytest.skip("no way on this grid")
    wave = plan.wave
    passable, kw = wave.passable, wave.kw
    clean = plan.analysis.clean
    free = np.argwhere(passable == 1)
    W = grid.shape[1]
    for _ in range(10):
        start = tuple(int(v) for v in free[rng.integers(len(free))])
        obstacles = free[rng.integers(len(free), size=6)]
        within = int(rng.integers(1, 6))
        cells, _ = detour_cells(
            passable, OPEN_PASSABLE, plan.goal[0] * W + plan.goal[1], clean,
            start[0] * W + start[1], obstacles, margin=0, diagonal_cost=wave.diagonal_cost,
            field=kw, within=within,
        )  # fmt: skip
        blocked = {tuple(o) for o in obstacles.tolist()}
        want = _slow_best(passable, kw, clean, start, blocked, within, wave.diagonal_cost)  # type: ignore[arg-type]
        goal_cut = (
            plan.goal in blocked
            and max(abs(plan.goal[0] - start[0]), abs(plan.goal[1] - start[1])) <= 2 * within
        )  # no way to the goal now: no detour
        assert not (goal_cut and cells.size)
        if cells.size == 0:
            assert want == math.inf or goal_cut, (start, within)
            continue
        route = np.concatenate(([start[0] * W + start[1]], cells))
        rows, cols = np.divmod(route, W)
        steps = np.where((np.diff(rows) != 0) & (np.diff(cols) != 0), wave.diagonal_cost, 1.0)
        got = float(steps.sum() + clean[rows[1:], cols[1:]].sum() + kw[rows[-1], cols[-1]])
        assert got == pytest.approx(want, rel=1e-9), (start, within)
        assert not blocked & {(int(r), int(c)) for r, c in zip(rows[1:], cols[1:], strict=True)}

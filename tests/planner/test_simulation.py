"""The paper's simulated experiment (ALGORITHM.md §5): seeded episodes and their metrics."""

from __future__ import annotations

import numpy as np
import pytest

import planner
from planner.cli import EXAMPLE_GOAL, EXAMPLE_MAP, EXAMPLE_START

METRICS = {
    "reached", "status", "iterations", "moves", "waits", "replans", "path_length", "arc_cost",
    "gates", "tunnels", "narrow_fallback", "min_clearance", "mean_clearance", "contact_ratio",
    "collisions", "analysis_ms", "step_us", "episode_ms",
}  # fmt: skip
TIMINGS = {"analysis_ms", "step_us", "episode_ms"}


def test_a_seeded_episode_is_reproducible() -> None:
    grid = planner.read_map(str(EXAMPLE_MAP))
    a = planner.simulate(grid, EXAMPLE_START, EXAMPLE_GOAL, dynamic_count=12, seed=5)
    b = planner.simulate(grid, EXAMPLE_START, EXAMPLE_GOAL, dynamic_count=12, seed=5)
    np.testing.assert_array_equal(a.trajectory, b.trajectory)
    np.testing.assert_array_equal(a.dynamic_obstacles, b.dynamic_obstacles)
    assert {k: v for k, v in a.metrics.items() if k not in TIMINGS} == {
        k: v for k, v in b.metrics.items() if k not in TIMINGS
    }
    c = planner.simulate(grid, EXAMPLE_START, EXAMPLE_GOAL, dynamic_count=12, seed=6)
    assert not np.array_equal(a.dynamic_obstacles, c.dynamic_obstacles)


@pytest.mark.parametrize("preset", sorted(planner.PRESETS))
@pytest.mark.parametrize("seed", range(6))
def test_episodes_reach_the_goal_without_collisions(preset: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = (rng.random((30, 30)) < 0.2).astype(np.uint8)
    grid[0, 0] = grid[29, 29] = 0
    try:
        e = planner.simulate(grid, (0, 0), (29, 29), preset=preset, dynamic_count=15, seed=seed)
    except planner.NoValidPath:
        return
    m = e.metrics
    assert set(m) == METRICS
    assert m["collisions"] == 0
    assert m["reached"]
    assert e.trajectory[0].tolist() == [0, 0]
    assert e.trajectory[-1].tolist() == [29, 29]
    assert m["moves"] == len(e.trajectory) - 1
    assert m["iterations"] == m["moves"] + m["waits"]
    assert e.dynamic_obstacles.shape == (m["iterations"] + 1, 15, 2)
    # Obstacles walk on free cells only, one legal move (or none) per step, never onto the robot.
    assert (grid[e.dynamic_obstacles[..., 0], e.dynamic_obstacles[..., 1]] == 0).all()
    assert np.abs(np.diff(e.dynamic_obstacles, axis=0)).max() <= 1
    k = e.plan.wave.k
    assert m["arc_cost"] == pytest.approx(float(k[e.trajectory[1:, 0], e.trajectory[1:, 1]].sum()))
    assert 0.0 <= m["contact_ratio"] <= 1.0
    assert m["min_clearance"] <= m["mean_clearance"]


def test_no_dynamic_obstacles_follows_the_preview() -> None:
    grid = planner.read_map(str(EXAMPLE_MAP))
    e = planner.simulate(grid, EXAMPLE_START, EXAMPLE_GOAL, dynamic_count=0)
    np.testing.assert_array_equal(e.trajectory, e.plan.path)
    assert e.metrics["path_length"] == pytest.approx(e.plan.length)


def test_bad_simulation_inputs_are_named() -> None:
    grid = np.zeros((3, 3), dtype=np.uint8)
    with pytest.raises(planner.InvalidInput, match="dynamic_count 8 exceeds the 7 free cells"):
        planner.simulate(grid, (0, 0), (2, 2), dynamic_count=8)
    with pytest.raises(planner.InvalidInput, match="dynamic_count must be an integer"):
        planner.simulate(grid, (0, 0), (2, 2), dynamic_count=-1)
    with pytest.raises(planner.InvalidInput, match="max_steps must be a positive integer; got 0"):
        planner.simulate(grid, (0, 0), (2, 2), max_steps=0)


def test_max_steps_bounds_an_episode() -> None:
    e = planner.simulate(
        np.zeros((1, 20), dtype=np.uint8), (0, 0), (0, 19), dynamic_count=0, max_steps=5
    )
    assert e.metrics["iterations"] == 5
    assert not e.metrics["reached"]


def test_many_obstacles_without_recording() -> None:
    grid = np.zeros((60, 60), dtype=np.uint8)
    e = planner.run_episode(
        planner.plan(grid, (0, 0), (59, 59)), dynamic_count=900, seed=2, record=False, max_steps=400
    )
    assert e.dynamic_obstacles.shape == (0, 900, 2)
    assert e.metrics["collisions"] == 0
    assert e.metrics["iterations"] >= 59


def crowded(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    grid = (rng.random((24, 24)) < 0.15).astype(np.uint8)
    grid[0, 0] = grid[23, 23] = 0
    return grid


def test_simultaneous_obstacles_move_after_the_robot_decides_and_never_onto_its_cell() -> None:
    grid = crowded(1)
    e = planner.simulate(
        grid, (0, 0), (23, 23), dynamic_count=30, seed=3, obstacle_motion="simultaneous"
    )
    assert e.obstacle_motion == "simultaneous"
    robot = recount_positions(e)  # decided from the obstacles at each tick's start
    moved = [cell for i, cell in enumerate(robot) if i == 0 or cell != robot[i - 1]]
    assert moved == [tuple(c) for c in e.trajectory.tolist()]
    for t in range(len(robot) - 1):
        assert robot[t] not in {tuple(o) for o in e.dynamic_obstacles[t + 1].tolist()}
    assert np.abs(np.diff(e.dynamic_obstacles, axis=0)).max() <= 1
    assert e.metrics["collisions"] == 0  # wide: dynamic_margin 1


@pytest.mark.parametrize("motion", ["turns", "simultaneous"])
def test_collisions_are_counted_honestly(motion: str) -> None:
    # A robot that only avoids the cells obstacles stand on (margin 0) meets them when they
    # move at the same time; with margin 1 it never does. In turns both never collide.
    hits = {0: 0, 1: 0}
    for seed in range(12):
        grid = crowded(seed)
        for margin in (0, 1):
            try:
                e = planner.simulate(
                    grid, (0, 0), (23, 23), preset="shortest", dynamic_count=60, seed=seed,
                    obstacle_motion=motion, dynamic_margin=margin,  # type: ignore[arg-type]
                )  # fmt: skip
            except planner.NoValidPath:
                continue
            hits[margin] += e.metrics["collisions"]
            # Recount from the record: the robot's cell after each tick against the obstacles'.
            robot = recount_positions(e)
            recount = sum(
                robot[t + 1] in {tuple(o) for o in e.dynamic_obstacles[t + 1].tolist()}
                or any(
                    tuple(a) == robot[t + 1] and tuple(b) == robot[t]
                    for a, b in zip(
                        e.dynamic_obstacles[t].tolist(),
                        e.dynamic_obstacles[t + 1].tolist(),
                        strict=True,
                    )
                )
                for t in range(len(robot) - 1)
            )
            assert recount == e.metrics["collisions"]
    assert hits[1] == 0
    if motion == "simultaneous":
        assert hits[0] > 0
    else:
        assert hits[0] == 0


def recount_positions(e: planner.Episode) -> list[tuple[int, int]]:
    """The robot's cell at the start and after every tick, from a re-run session's steps (as
    the simulation runs it: the grid decision, no path ahead)."""
    session = planner.Session(e.plan, poses=False)
    out = [session.state.position]
    for t in range(len(e.dynamic_obstacles) - 1):
        seen = (
            e.dynamic_obstacles[t + 1] if e.obstacle_motion == "turns" else e.dynamic_obstacles[t]
        )
        out.append(session.step(seen).position)
    return out


def test_bad_obstacle_motion_is_named() -> None:
    with pytest.raises(planner.InvalidInput, match="obstacle_motion must be 'turns' or"):
        planner.simulate(
            np.zeros((3, 3), dtype=np.uint8),
            (0, 0),
            (2, 2),
            obstacle_motion="later",  # type: ignore[arg-type]
        )

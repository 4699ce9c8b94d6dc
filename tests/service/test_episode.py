"""Whole episodes over HTTP against a real uvicorn server: the two-call flow, and a client whose
obstacles move at random while it checks that every answered move is legal."""

from __future__ import annotations

import httpx
import numpy as np

from tests.service.conftest import random_map

NEIGHBOURS = [(-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1)]
MOVES = dict(zip(NEIGHBOURS, ["N", "NE", "E", "SE", "S", "SW", "W", "NW"], strict=True))


def test_two_calls_then_steps_reach_the_goal(live_url: str) -> None:
    rows = ["..........", "..@@@@@@..", "..........", "@@@@@@@@.."]
    with httpx.Client(base_url=live_url) as client:
        r = client.post("/maps", json={"rows": rows, "start": [0, 0], "goal": [2, 0]})
        assert r.status_code == 201
        plan = r.json()["plan"]
        position, status, seq = plan["position"], plan["status"], 0
        while status != "arrived":
            step = client.post(f"/plan/{plan['plan_id']}/step", json={"seq": seq})
            assert step.status_code == 200
            assert step.json()["previous"] == position
            position, status = step.json()["position"], step.json()["status"]
            seq += 1
            assert seq <= len(plan["preview"]["path"])
        assert position == [2, 0]
        assert (
            client.get(f"/plan/{plan['plan_id']}").json()["trajectory"] == plan["preview"]["path"]
        )


def _move_obstacles(
    grid: np.ndarray,
    obstacles: list[tuple[int, int]],
    robot: tuple[int, int],
    rng: np.random.Generator,
) -> list[tuple[int, int]]:
    """Each obstacle moves to a random free neighbouring cell or stays, never onto another
    obstacle or the robot (the rule of the paper's experiment)."""
    H, W = grid.shape
    taken = set(obstacles)
    for i, (r, c) in enumerate(obstacles):
        options = [(r, c)]
        for dr, dc in NEIGHBOURS:
            cell = (r + dr, c + dc)
            inside = 0 <= cell[0] < H and 0 <= cell[1] < W
            if inside and grid[cell] == 0 and cell not in taken and cell != robot:
                options.append(cell)
        new = options[int(rng.integers(len(options)))]
        taken.discard((r, c))
        taken.add(new)
        obstacles[i] = new
    return obstacles


def _assert_legal(
    grid: np.ndarray,
    blocked: set[tuple[int, int]],
    answer: dict[str, object],
    here: tuple[int, int],
) -> tuple[int, int]:
    previous, position = answer["previous"], answer["position"]
    assert isinstance(previous, list)
    assert isinstance(position, list)
    assert tuple(previous) == here
    there = (position[0], position[1])
    if answer["move"] == "WAIT":
        assert there == here
        return here
    dr, dc = there[0] - here[0], there[1] - here[1]
    assert MOVES[(dr, dc)] == answer["move"]
    assert grid[there] == 0, f"{here} -> {there} enters a static obstacle"
    assert there not in blocked, f"{here} -> {there} enters a dynamic obstacle's cell"
    if dr and dc:  # no corner cutting: both cells passed between are free
        for side in ((here[0] + dr, here[1]), (here[0], here[1] + dc)):
            assert grid[side] == 0, f"{here} -> {there} cuts the corner of {side}"
            assert side not in blocked, f"{here} -> {there} squeezes past {side}"
    return there


def test_episode_among_randomly_moving_obstacles(live_url: str) -> None:
    rng = np.random.default_rng(11)
    grid = random_map(24, 24, 0.15, seed=3)
    start, goal = (0, 0), (23, 23)
    free = [(int(r), int(c)) for r, c in np.argwhere(grid == 0)]
    free = [cell for cell in free if cell not in (start, goal)]
    obstacles: list[tuple[int, int]] = [
        free[int(i)] for i in rng.choice(len(free), 8, replace=False)
    ]
    with httpx.Client(base_url=live_url) as client:
        r = client.post(
            "/maps", json={"grid": grid.tolist(), "start": list(start), "goal": list(goal)}
        )
        assert r.status_code == 201
        plan_id = r.json()["plan"]["plan_id"]
        here, status, visited = start, "ready", [start]
        moved = 0
        for seq in range(2000):
            obstacles = _move_obstacles(grid, obstacles, here, rng)
            body = {"seq": seq, "dynamic_obstacles": [list(cell) for cell in obstacles]}
            answer = client.post(f"/plan/{plan_id}/step", json=body)
            assert answer.status_code == 200, answer.text
            new = _assert_legal(grid, set(obstacles), answer.json(), here)
            moved += new != here
            if new != here:
                visited.append(new)
            here, status = new, answer.json()["status"]
            if status == "arrived":
                break
        assert status == "arrived"
        assert here == goal
        assert moved >= 23
        detail = client.get(f"/plan/{plan_id}").json()
        assert [tuple(cell) for cell in detail["trajectory"]] == visited

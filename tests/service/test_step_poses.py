"""Stepping with poses over HTTP: a robot reporting off-center points (with headings) among
circles on its way; every answer's poses checked by brute force against the same plan made
locally, a retried ``seq`` answering the very same poses."""

from __future__ import annotations

import math
from typing import Any

import httpx
import numpy as np
import pytest

import planner
from tests.planner.test_poses import point_in
from tests.planner.test_step_poses import check_step_poses, length

pytestmark = pytest.mark.anyio

RES, ORIGIN, RADIUS, HORIZON = 0.1, (-1.0, 2.0, 0.2), 0.12, 1.2


def room() -> np.ndarray:
    grid = np.zeros((24, 36), dtype=np.uint8)
    grid[6:18, 12] = 1
    grid[0:10, 24] = 1
    grid[14:24, 24] = 1
    return grid


def as_step(answer: dict[str, Any]) -> planner.Step:
    poses = [[p["x"], p["y"], p["yaw"]] for p in answer["poses"]]
    return planner.Step.from_dict({**answer, "poses": poses})


async def test_an_episode_of_points_among_circles_has_clear_poses(
    client: httpx.AsyncClient,
) -> None:
    grid = room()
    robot_map = planner.grid_map(grid, resolution=RES, origin=ORIGIN)
    body = {"grid": grid.tolist(), "resolution": RES, "origin": list(ORIGIN)}
    map_id = (await client.post("/maps", json=body)).json()["map_id"]
    params = {"robot_radius": RADIUS, "params": {"horizon_m": HORIZON}}
    made = await client.post(
        "/plan", json={"map_id": map_id, "start": [20, 2], "goal": [3, 33], **params}
    )
    assert made.status_code == 201, made.text
    assert made.json()["params"]["horizon_m"] == HORIZON
    plan_id = made.json()["plan_id"]
    local = planner.plan(robot_map, [20, 2], [3, 33], robot_radius=RADIUS, horizon_m=HORIZON)
    path = local.path.tolist()
    rng = np.random.default_rng(7)
    position: list[int] = [20, 2]
    remaining = []
    answer: dict[str, Any] = {}
    for seq in range(150):
        point = point_in(robot_map.frame, position, *rng.uniform(-0.3, 0.3, size=2))
        yaw = float(rng.uniform(-math.pi, math.pi))
        here = path.index(position) if position in path else 0
        circles = []
        if seq % 3:
            ahead = path[min(here + int(rng.integers(5, 14)), len(path) - 2)]
            x, y = point_in(robot_map.frame, ahead, *rng.uniform(-0.5, 0.5, size=2))
            circles.append({"x": x, "y": y, "radius": 0.12})
        request = {
            "seq": seq,
            "position": {"x": point[0], "y": point[1], "yaw": yaw},
            "dynamic_obstacles": circles,
        }
        r = await client.post(f"/plan/{plan_id}/step", json=request)
        assert r.status_code == 200, r.text
        answer = r.json()
        obstacles = planner.circle_cells(robot_map, circles, robot_radius=RADIUS)
        step = as_step(answer)
        problems = check_step_poses(local, step, obstacles, point=point, yaw=yaw, circles=circles)
        assert problems == [], (problems, request, answer)
        assert answer["poses"][0] == {"x": point[0], "y": point[1], "yaw": yaw}
        goal_xy = robot_map.frame.centers([[3, 33]])[0].tolist()
        if length(step.poses) < HORIZON - 1e-9 and [*step.poses[-1][:2]] != goal_xy:
            assert circles or answer["move"] == "WAIT", answer
        # The retry: the very same answer, poses included.
        again = await client.post(f"/plan/{plan_id}/step", json=request)
        assert again.json() == answer
        remaining.append(answer["remaining_m"])
        position = answer["position"]
        if answer["status"] == "arrived":
            break
    assert answer["status"] == "arrived"
    assert remaining[-1] == pytest.approx(float(np.hypot(*(np.array(goal_xy) - point))))
    assert remaining[0] > remaining[len(remaining) // 2] > remaining[-1]


async def test_without_a_point_the_poses_start_at_the_cell_moved_to(
    client: httpx.AsyncClient,
) -> None:
    made = await client.post(
        "/maps", json={"rows": ["." * 12] * 6, "start": [0, 0], "goal": [5, 11]}
    )
    plan_id = made.json()["plan"]["plan_id"]
    answer = (await client.post(f"/plan/{plan_id}/step", json={})).json()
    assert answer["position"] == [1, 1]
    first = answer["poses"][0]
    assert [first["x"], first["y"]] == answer["position_xy"] == [1.5, 4.5]
    assert length([[p["x"], p["y"], p["yaw"]] for p in answer["poses"]]) >= 2.0
    assert answer["remaining_m"] == pytest.approx(answer["remaining"], rel=0.05)

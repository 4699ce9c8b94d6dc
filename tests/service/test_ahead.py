"""The path ahead goes around, over HTTP: on a shared ROS map, a step with a circle just ahead
answers poses of the horizon round it in that same step; a corridor cut for good answers
``waiting`` with ``blocked_at``, a point; with nothing in the way, ``blocked_at`` is null."""

from __future__ import annotations

from pathlib import Path

import httpx
import numpy as np
import pytest

import planner
from service.config import Settings
from tests.planner.test_step_poses import check_step_poses, length
from tests.service.test_step_poses import as_step

pytestmark = pytest.mark.anyio

RADIUS, CIRCLE = 0.22, 0.3


@pytest.fixture
def settings() -> Settings:
    return Settings(max_body_bytes=1 << 20)  # a ROS map's image


async def test_a_circle_just_ahead_is_gone_round_over_http(
    client: httpx.AsyncClient, ros: Path
) -> None:
    robot_map = planner.read_ros_map(ros / "smoothers_world.yaml")
    files = {
        "yaml": ("m.yaml", (ros / "smoothers_world.yaml").read_bytes()),
        "image": ("m.pgm", (ros / "smoothers_world.pgm").read_bytes()),
    }
    made = await client.post("/maps", files=files)
    assert made.status_code == 201, made.text
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=RADIUS))
    free = np.argwhere(analysis.passable() == 1)
    start, goal = (free[np.abs(free - corner).sum(axis=1).argmin()].tolist() for corner in
                   ([250, 40], [40, 250]))  # fmt: skip
    body = {"map_id": made.json()["map_id"], "start": start, "goal": goal, "robot_radius": RADIUS}
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    plan_id = r.json()["plan_id"]
    local = planner.plan(robot_map, start, goal, robot_radius=RADIUS, analysis=analysis)
    xy = robot_map.frame.centers(local.path.tolist())
    along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))
    rng = np.random.default_rng(4)
    seq = tried = 0
    for i in range(0, len(xy) - 1, 20):
        j = int(np.searchsorted(along, along[i] + rng.uniform(0.6, 1.6)))
        if j >= len(xy) - 1:
            break
        circle = {"x": float(xy[j, 0]), "y": float(xy[j, 1]), "radius": CIRCLE}
        cells = planner.circle_cells(robot_map, [circle], robot_radius=RADIUS)
        if len(planner.detour(local, local.path[i].tolist(), cells)) == 0:
            continue  # no way round
        point = (float(xy[i, 0]), float(xy[i, 1]))
        step = {"seq": seq, "position": {"x": point[0], "y": point[1]}}
        answer = (
            await client.post(f"/plan/{plan_id}/step", json={**step, "dynamic_obstacles": [circle]})
        ).json()
        seq += 1
        tried += 1
        got = as_step(answer)
        problems = check_step_poses(local, got, cells, point=point, yaw=None, circles=[circle])
        assert problems == [], (problems, circle)
        end = [answer["poses"][-1]["x"], answer["poses"][-1]["y"]]
        assert local.goal_point is not None
        assert length(got.poses) >= 2.0 or np.allclose(end, local.goal_point), (i, circle)
        assert answer["status"] == "replanned"
        assert answer["blocked_at"] is None
    assert tried >= 3


async def test_a_corridor_cut_for_good_answers_waiting_and_blocked_at(
    client: httpx.AsyncClient,
) -> None:
    grid = np.ones((7, 40), dtype=np.uint8)
    grid[2:5, :] = 0  # a corridor three cells wide, 4 m long
    body = {"grid": grid.tolist(), "resolution": 0.1, "start": [3, 0], "goal": [3, 39]}
    made = (await client.post("/maps", json=body)).json()
    plan_id = made["plan"]["plan_id"]
    wall = {"x": 2.05, "y": 0.35, "radius": 0.2}  # across the corridor, 2 m ahead
    answers = []
    for seq in range(30):
        r = await client.post(
            f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": [wall]}
        )
        assert r.status_code == 200, r.text
        answers.append(r.json())
    assert answers[-1]["status"] == "waiting"
    assert answers[-1]["move"] == "WAIT"
    assert all(a["blocked_at"] is not None for a in answers)
    assert abs(answers[-1]["blocked_at"]["x"] - 2.05) <= 0.2 + 0.2  # the margin, a cell
    assert abs(answers[-1]["blocked_at"]["y"] - 0.35) <= 0.25
    freed = (await client.post(f"/plan/{plan_id}/step", json={"seq": 30})).json()
    assert freed["status"] == "moving"
    assert freed["blocked_at"] is None


async def test_with_no_obstacle_the_steps_follow_the_plan_as_before(
    client: httpx.AsyncClient,
) -> None:
    grid = np.zeros((12, 30), dtype=np.uint8)
    grid[3:9, 10] = 1
    body = {"grid": grid.tolist(), "resolution": 0.1, "start": [6, 0], "goal": [6, 29]}
    made = (await client.post("/maps", json=body)).json()
    plan_id = made["plan"]["plan_id"]
    local = planner.plan(planner.grid_map(grid, resolution=0.1), [6, 0], [6, 29])
    grid_session = planner.Session(local, poses=False)  # the grid decision alone
    for seq in range(40):
        answer = (await client.post(f"/plan/{plan_id}/step", json={"seq": seq})).json()
        want = grid_session.step([])
        assert (answer["position"], answer["move"], answer["status"]) == (
            list(want.position), want.move, want.status,
        )  # fmt: skip
        assert answer["blocked_at"] is None
        if want.status == "arrived":
            break
    assert want.status == "arrived"

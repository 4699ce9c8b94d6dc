"""Poses over HTTP (API.md "Poses"): every plan answer's poses against the brute-force checker,
headings in, ``goal_tolerance``, ``GET /plan/{id}/path`` as a ``nav_msgs/Path``, plans rebuilt
from their records (memory and Redis), and bad yaws, tolerances and frame ids."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import orjson
import pydantic
import pytest
from fastapi import FastAPI

import planner
import schemas
from service.config import Settings
from service.main import create_app
from tests import naive_poses
from tests.conftest import ROS_MAP_NAMES
from tests.service.conftest import RedisServer, running

pytestmark = pytest.mark.anyio

RADIUS = 0.22
ROWS = ["..........", "..@@@@....", "..@.......", "..@..@@@..", ".....@....", ".....@...."]


@pytest.fixture
def settings() -> Settings:
    return Settings(pool_size=2)


def grid_of(rows: list[str]) -> np.ndarray:
    return np.array([[ch == "@" for ch in row] for row in rows], dtype=np.int8)


def check_answer(preview: dict[str, Any], plan: planner.Plan) -> None:
    """The answer's poses meet every rule (against the same plan made locally), and are its."""
    a = plan.analysis
    cs = a.cspace
    poses = np.array([[p["x"], p["y"], p["yaw"]] for p in preview["poses"]])
    goal = plan.goal_used if plan.goal_used is not None else plan.goal_point
    check = naive_poses.check_poses(
        poses,
        np.array(preview["path"]),
        a.clearance,
        resolution=a.frame.resolution,
        origin=a.frame.origin,
        robot_radius=cs.robot_radius if cs is not None else 0.0,
        start=plan.start_point,
        goal=goal,
        start_yaw=plan.start_yaw,
        goal_yaw=plan.goal_yaw,
        outside_blocked=cs is None or cs.unknown == "blocked",
    )
    assert check.problems == []
    assert poses.tolist() == plan.poses.tolist()
    assert preview["length_poses_m"] == pytest.approx(check.length_m, abs=1e-6)
    assert preview["length_poses_m"] <= preview["length_m"] + 1e-6 + np.hypot(
        *(np.array(goal) - np.array(preview["path_xy"][-1]))
    ) + np.hypot(*(np.array(plan.start_point) - np.array(preview["path_xy"][0])))


@pytest.mark.parametrize("preset", list(schemas.PRESET_NAMES))
async def test_every_plan_answer_has_poses_that_meet_every_rule(
    client: httpx.AsyncClient, preset: str
) -> None:
    start = {"x": 0.3, "y": 0.7, "yaw": 2.0}
    goal = {"x": 9.6, "y": 5.4, "yaw": -0.5}
    r = await client.post(
        "/maps", json={"rows": ROWS, "start": start, "goal": goal, "preset": preset}
    )
    assert r.status_code == 201, r.text
    answer = r.json()["plan"]
    local = planner.plan(grid_of(ROWS), start, goal, preset=preset)
    check_answer(answer["preview"], local)
    assert answer["preview"]["poses"][-1]["yaw"] == pytest.approx(-0.5)
    assert answer["preview"]["goal_used"] is None
    body = {"map_id": answer["map_id"], "start": start, "goal": goal, "preset": preset}
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    assert r.json()["preview"] == answer["preview"]
    r = await client.get(f"/plan/{answer['plan_id']}")
    assert r.json()["preview"] == answer["preview"]


async def test_plans_rebuilt_from_their_records_keep_their_poses(
    app: FastAPI, client: httpx.AsyncClient
) -> None:
    body = {"rows": ROWS, "start": [5, 0], "goal": {"x": 6.5, "y": 2.5, "yaw": 1.0}}
    r = await client.post("/maps", json={**body, "goal_tolerance": 1.5})
    plan = r.json()["plan"]
    # Cells [2, 6] and [4, 6] are nearest (1 m), reachable: the first by row.
    assert plan["preview"]["goal_used"] == {"x": 6.5, "y": 3.5}
    app.state.engine._plans.clear()  # the memo of built plans: GET rebuilds from the record
    again = (await client.get(f"/plan/{plan['plan_id']}")).json()
    assert again["preview"] == plan["preview"]


async def test_redis_records_keep_the_ends(redis_server: RedisServer) -> None:
    settings = Settings(pool_size=2, store_url=redis_server.url)
    previews: list[dict[str, Any]] = []
    for _ in range(2):  # a second service on the same store rebuilds the plan from its record
        app = create_app(settings)
        async with running(app):
            transport = httpx.ASGITransport(app=app)
            async with httpx.AsyncClient(transport=transport, base_url="http://s") as client:
                if not previews:
                    body = {
                        "rows": ROWS, "start": {"x": 0.2, "y": 0.3, "yaw": 3.0},
                        "goal": {"x": 3.4, "y": 4.4, "yaw": -2.0}, "goal_tolerance": 1.0,
                    }  # fmt: skip
                    plan = (await client.post("/maps", json=body)).json()["plan"]
                    previews.append(plan["preview"])
                    plan_id = plan["plan_id"]
                else:
                    previews.append((await client.get(f"/plan/{plan_id}")).json()["preview"])
    assert previews[0]["goal_used"] == {"x": 3.5, "y": 3.5}  # the goal's cell [1, 3] is a wall
    assert previews[0]["goal_offset_m"] == pytest.approx(math.hypot(0.1, 0.9), abs=1e-6)
    assert previews[1] == previews[0]


@pytest.mark.parametrize("name", ROS_MAP_NAMES)
async def test_poses_on_the_ros_maps(client: httpx.AsyncClient, ros: Path, name: str) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    radius = RADIUS if robot_map.resolution <= 0.05 else 2.0 * robot_map.resolution / 3
    r = await client.post("/maps", json={"occupancy_grid": robot_map.to_occupancy_grid()})
    assert r.status_code in (200, 201), r.text
    map_id = r.json()["map_id"]
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=radius))
    cells = np.argwhere(analysis.passable() == 1)
    rng = np.random.default_rng(sum(map(ord, name)))
    span = max(np.ptp(cells[:, 0]), np.ptp(cells[:, 1]))
    done = 0
    for _ in range(100):
        s, g = cells[rng.integers(len(cells), size=2)]
        if math.hypot(*(s - g)) < span / 3:
            continue
        (sx, sy), (gx, gy) = robot_map.frame.centers([s, g]).tolist()
        start, goal = {"x": sx, "y": sy}, {"x": gx, "y": gy, "yaw": float(rng.uniform(-3, 3))}
        body = {"map_id": map_id, "start": start, "goal": goal, "robot_radius": radius}
        r = await client.post("/plan", json=body)
        if r.status_code == 422:
            assert "NO_VALID_PATH" in r.json()["detail"], r.text
            continue
        assert r.status_code == 201, r.text
        local = planner.plan(robot_map, start, goal, analysis=analysis, robot_radius=radius)
        check_answer(r.json()["preview"], local)
        done += 1
        if done == 2:
            break
    assert done == 2


async def test_the_path_is_a_nav_msgs_path(client: httpx.AsyncClient) -> None:
    goal = {"x": 9.5, "y": 5.5, "yaw": 2.0}
    r = await client.post("/maps", json={"rows": ROWS, "start": [5, 0], "goal": goal})
    plan = r.json()["plan"]
    poses = plan["preview"]["poses"]
    for query, frame_id in (
        ({}, "map"),
        ({"frame_id": "odom"}, "odom"),
        ({"frame_id": "/a/b_c.d-1"}, "/a/b_c.d-1"),
    ):
        r = await client.get(f"/plan/{plan['plan_id']}/path", params=query)
        assert r.status_code == 200, r.text
        path = r.json()
        assert schemas.NavPath.model_validate(path).model_dump(mode="json") == path
        header = path["header"]
        assert header["frame_id"] == frame_id
        assert set(header["stamp"]) == {"sec", "nanosec"}
        assert 0 <= header["stamp"]["nanosec"] < 10**9
        assert len(path["poses"]) == len(poses)
        for stamped, pose in zip(path["poses"], poses, strict=True):
            assert stamped["header"] == header
            position, q = stamped["pose"]["position"], stamped["pose"]["orientation"]
            assert position == {"x": pose["x"], "y": pose["y"], "z": 0.0}
            assert (q["x"], q["y"]) == (0.0, 0.0)
            assert math.hypot(q["z"], q["w"]) == pytest.approx(1.0)
            assert 2 * math.atan2(q["z"], q["w"]) == pytest.approx(
                math.atan2(math.sin(pose["yaw"]), math.cos(pose["yaw"])), abs=1e-12
            ) or abs(pose["yaw"]) == pytest.approx(math.pi)
        last = path["poses"][-1]["pose"]["orientation"]
        assert (last["z"], last["w"]) == pytest.approx((math.sin(1.0), math.cos(1.0)))
    r = await client.get("/plan/" + "0" * 32 + "/path")
    assert r.status_code == 404
    spec = (await client.get("/openapi.json")).json()
    ok = spec["paths"]["/plan/{plan_id}/path"]["get"]["responses"]["200"]
    assert ok["content"]["application/json"]["schema"] == {"$ref": "#/components/schemas/NavPath"}


@pytest.mark.parametrize(
    "frame_id", ["", " map", "map frame", "x" * 129, "../etc", "map\n", "ç", "-map"]
)
async def test_a_bad_frame_id_is_a_422_naming_it(client: httpx.AsyncClient, frame_id: str) -> None:
    r = await client.post("/maps", json={"rows": ROWS, "start": [5, 0], "goal": [0, 9]})
    plan_id = r.json()["plan"]["plan_id"]
    r = await client.get(f"/plan/{plan_id}/path", params={"frame_id": frame_id})
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "frame_id"
    assert "frame_id" in r.json()["detail"]


BAD = [
    ({"goal": {"x": 9.5, "y": 5.5, "yaw": "north"}}, "goal.yaw"),
    ({"goal": {"x": 9.5, "y": 5.5, "yaw": True}}, "goal.yaw"),
    ({"start": {"x": 0.5, "y": 0.5, "yaw": [1.0]}}, "start.yaw"),
    ({"goal": [0, 9, 1]}, "goal"),
    ({"goal_tolerance": -0.5}, "goal_tolerance"),
    ({"goal_tolerance": 1e9}, "goal_tolerance"),
    ({"goal_tolerance": "0.5"}, "goal_tolerance"),
]


@pytest.mark.parametrize(("fields", "field"), BAD)
async def test_bad_yaws_and_tolerances_are_422_naming_the_field(
    client: httpx.AsyncClient, fields: dict[str, Any], field: str
) -> None:
    r = await client.post("/maps", json={"rows": ROWS})
    map_id = r.json()["map_id"]
    body = {"start": [5, 0], "goal": [0, 9], **fields}
    for url, extra in (("/plan", {"map_id": map_id}), ("/maps", {"rows": ROWS})):
        r = await client.post(url, json={**body, **extra})
        assert r.status_code == 422, r.text
        assert r.json()["field"] == field, r.json()
    r = await client.post(f"/maps/{map_id}/simulate", json={**body, "dynamic_count": 1, "seed": 1})
    assert r.status_code == 422, r.text
    assert r.json()["field"] == field


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity", "1e999"])
async def test_non_finite_yaws_and_tolerances_are_422(
    client: httpx.AsyncClient, token: str
) -> None:
    map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
    texts = (
        f'{{"map_id": "{map_id}", "start": [5, 0], "goal": {{"x": 9.5, "y": 5.5, "yaw": {token}}}'
        "}",
        f'{{"map_id": "{map_id}", "start": [5, 0], "goal": [0, 9], "goal_tolerance": {token}}}',
    )
    for text, field in zip(texts, ("goal.yaw", "goal_tolerance"), strict=True):
        r = await client.post("/plan", content=text, headers={"content-type": "application/json"})
        # JSON has no non-finite numbers: the body is refused as malformed, where the token is.
        assert r.status_code == 422, r.text
        assert r.json()["code"] == "INVALID_INPUT"
        assert "malformed JSON" in r.json()["detail"]
        # What a Python client validates with the schema names the field.
        body = orjson.loads(text.replace(token, "0"))
        if field == "goal.yaw":
            body["goal"]["yaw"] = float(token.replace("1e999", "inf"))
        else:
            body["goal_tolerance"] = float(token.replace("1e999", "inf"))
        with pytest.raises(pydantic.ValidationError) as e:
            schemas.PlanCreate.model_validate(body)
        assert ".".join(map(str, e.value.errors()[0]["loc"])).replace("point.", "") == field


async def test_goal_tolerance_with_a_goal_inside_a_wall(client: httpx.AsyncClient) -> None:
    rows = ["..........", "..........", "....@@@@..", "....@@@@..", ".........."]
    inside = {"x": 5.5, "y": 2.4, "yaw": -1.0}  # cell [2, 5]: in the wall, 0.6 m from its edge
    map_id = (await client.post("/maps", json={"rows": rows})).json()["map_id"]
    for tolerance in (0, 0.5):
        body = {"map_id": map_id, "start": [0, 0], "goal": inside, "goal_tolerance": tolerance}
        r = await client.post("/plan", json=body)
        assert r.status_code == 422, r.text
        assert r.json()["field"] == "goal"
        assert "obstacle" in r.json()["detail"]
    body = {"map_id": map_id, "start": [0, 0], "goal": inside, "goal_tolerance": 1.5}
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    preview = r.json()["preview"]
    assert preview["goal_used"] == {"x": 5.5, "y": 3.5}  # cell [1, 5]'s center, 1.1 m away
    assert preview["goal_offset_m"] == pytest.approx(1.1)
    assert preview["poses"][-1] == {"x": 5.5, "y": 3.5, "yaw": pytest.approx(-1.0)}
    local = planner.plan(grid_of(rows), [0, 0], inside, goal_tolerance=1.5)
    check_answer(preview, local)
    r = await client.post(
        f"/maps/{map_id}/simulate",
        json={
            "start": [0, 0],
            "goal": inside,
            "goal_tolerance": 1.5,
            "dynamic_count": 1,
            "seed": 1,
        },
    )
    assert r.status_code == 200, r.text
    assert r.json()["trajectory"][0] == [0, 0]


async def test_a_step_position_may_carry_a_yaw(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={"rows": ROWS, "start": [5, 0], "goal": [0, 9]})
    plan_id = r.json()["plan"]["plan_id"]
    position = {"x": 0.5, "y": 0.5, "yaw": 0.3}
    r = await client.post(f"/plan/{plan_id}/step", json={"seq": 0, "position": position})
    assert r.status_code == 200, r.text
    r = await client.post(
        f"/plan/{plan_id}/step", json={"seq": 1, "position": {"x": 0.5, "y": 0.5, "yaw": "e"}}
    )
    assert r.status_code == 422
    assert r.json()["field"] == "position.yaw"

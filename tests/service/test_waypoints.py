"""Waypoints over HTTP, on both stores: a plan through them on a grid and on a shared ROS map, an
episode stepped along the whole route (a retried ``seq`` replayed), ``GET /plan/{id}`` showing
the route, ``POST /maps`` with a plan through waypoints, the client sending them, and bad
waypoints refused naming the field."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

import planner
import schemas
from service.client import PlannerClient
from service.config import Settings
from tests.conftest import grid_from
from tests.service.conftest import RedisServer

pytestmark = pytest.mark.anyio

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


@pytest.fixture(params=["memory", "redis"])
def settings(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Settings]:
    if request.param == "memory":
        yield Settings(pool_size=2)
        return
    server = RedisServer(tmp_path / "redis")
    server.start()
    try:
        yield Settings(pool_size=2, store_url=server.url)
    finally:
        server.stop()


def visits_in_order(path: Any, cells: list[Any]) -> list[int]:
    rows = [list(cell) for cell in path]
    at, out = 0, []
    for cell in cells:
        at = rows.index(list(cell), at)
        out.append(at)
    return out


def check_preview(plan: dict[str, Any], waypoints: list[Any], frame: planner.MapFrame) -> None:
    preview = plan["preview"]
    cells = [list(frame.cell_of(w)) if isinstance(w, dict) else w for w in waypoints]
    assert plan["waypoints"] == cells
    visits_in_order(preview["path"], [plan["start"], *cells, plan["goal"]])
    indices = preview["waypoint_indices"]
    assert len(indices) == len(waypoints)
    poses = preview["poses"]
    for i, w in zip(indices, waypoints, strict=True):
        x, y = (w["x"], w["y"]) if isinstance(w, dict) else frame.centers([w])[0].tolist()
        assert (poses[i]["x"], poses[i]["y"]) == pytest.approx((x, y), abs=1e-9)
        if isinstance(w, dict) and "yaw" in w:
            assert poses[i]["yaw"] == pytest.approx(w["yaw"], abs=1e-9)
    steps = np.hypot(*np.diff([[p["x"], p["y"]] for p in poses], axis=0).T)
    assert preview["length_poses_m"] == pytest.approx(float(steps.sum()), abs=1e-5)


async def test_a_plan_through_waypoints_on_a_grid_and_its_episode(
    client: httpx.AsyncClient,
) -> None:
    r = await client.post("/maps", json={"grid": GRID.tolist()})
    map_id = r.json()["map_id"]
    waypoints: list[Any] = [[6, 1], {"x": 8.5, "y": 5.5, "yaw": 1.0}, [0, 15]]
    body = {"map_id": map_id, "start": [0, 0], "goal": [7, 15], "waypoints": waypoints}
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    plan = r.json()
    frame = planner.grid_map(GRID).frame
    check_preview(plan, waypoints, frame)
    same = planner.plan(GRID, [0, 0], [7, 15], waypoints=waypoints)
    assert plan["preview"]["path"] == same.path.tolist()
    assert plan["preview"]["waypoint_indices"] == same.waypoint_indices
    plan_id = plan["plan_id"]
    shown = (await client.get(f"/plan/{plan_id}")).json()
    assert (shown["waypoints"], shown["leg"]) == (plan["waypoints"], 0)
    assert shown["preview"] == plan["preview"]
    # The episode, with no obstacles: every waypoint in order, then the goal.
    answers = []
    for seq in range(100):
        r = await client.post(f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": []})
        assert r.status_code == 200, r.text
        answers.append(r.json())
        if seq == 12:  # a retry replays the same answer, moving nothing
            again = await client.post(
                f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": []}
            )
            assert again.json() == answers[-1]
        if answers[-1]["status"] == "arrived":
            break
    statuses = [a["status"] for a in answers]
    assert statuses[-1] == "arrived"
    assert set(statuses[:-1]) == {"moving"}
    trajectory = [[0, 0], *(a["position"] for a in answers)]
    assert trajectory == plan["preview"]["path"]
    visits_in_order(trajectory, [*plan["waypoints"], plan["goal"]])
    # remaining covers the rest of the route: on arriving at each waypoint, the legs after it.
    assert same.route is not None
    costs = same.route.costs
    arrivals = visits_in_order(trajectory, plan["waypoints"])
    for leg, i in enumerate(arrivals, start=1):
        assert answers[i - 1]["remaining"] == pytest.approx(sum(costs[leg:]))
        assert answers[i - 1]["remaining_m"] > sum(costs[leg + 1 :])  # 1 m cells
    assert answers[-1]["remaining"] == answers[-1]["remaining_m"] == 0.0
    done = (await client.get(f"/plan/{plan_id}")).json()
    assert (done["status"], done["leg"], done["position"]) == ("arrived", 3, [7, 15])
    assert done["trajectory"] == trajectory


async def test_a_plan_through_waypoints_on_a_shared_ros_map(
    client: httpx.AsyncClient, ros: Path
) -> None:
    m = planner.read_ros_map(ros / "tb3_sandbox.yaml")
    r = await client.post("/maps", json={"occupancy_grid": m.to_occupancy_grid()})
    assert r.status_code in (200, 201), r.text
    map_id = r.json()["map_id"]
    cs = planner.configuration_space(m, robot_radius=RADIUS)
    cells = np.argwhere(cs.traversable == 1)
    rng = np.random.default_rng(3)
    made = 0
    for _ in range(30):
        points = m.frame.centers(cells[rng.integers(len(cells), size=4)]).tolist()
        start, *waypoints, goal = [{"x": x, "y": y} for x, y in points]
        waypoints[0]["yaw"] = -2.0
        body = {
            "map_id": map_id, "start": start, "goal": goal, "waypoints": waypoints,
            "robot_radius": RADIUS,
        }  # fmt: skip
        r = await client.post("/plan", json=body)
        if r.status_code == 422:  # a point in a room with no way to it
            assert "NO_VALID_PATH" in r.json()["detail"], r.text
            continue
        assert r.status_code == 201, r.text
        check_preview(r.json(), waypoints, m.frame)
        made += 1
        if made == 2:
            break
    assert made == 2


async def test_a_map_uploaded_with_a_plan_through_waypoints(client: httpx.AsyncClient) -> None:
    body = {"grid": GRID.tolist(), "start": [0, 0], "goal": [7, 15], "waypoints": [[6, 1]]}
    r = await client.post("/maps", json=body)
    assert r.status_code == 201, r.text
    plan = r.json()["plan"]
    check_preview(plan, [[6, 1]], planner.grid_map(GRID).frame)
    r = await client.post("/maps", json={"grid": GRID.tolist(), "waypoints": [[6, 1]]})
    assert r.status_code == 422
    assert "waypoints" in r.json()["detail"]


BAD = [
    ([[0, 1]] * 65, "waypoints", "at most 64"),
    ([[0, 1], [1, 2]], "waypoints[1]", "obstacle"),  # a wall
    ([[8, 0]], "waypoints[0]", "outside"),
    ([{"x": 20.5, "y": 1.0}], "waypoints[0]", "outside"),
    ([[2, 3, 1.5]], "waypoints", "waypoints[0]"),  # a yaw on a cell
    ([{"x": 1.5, "y": 1.5, "yaw": "north"}], "waypoints", "waypoints[0]"),
]


@pytest.mark.parametrize(("waypoints", "field", "said"), BAD)
async def test_bad_waypoints_are_422_naming_the_field(
    client: httpx.AsyncClient, waypoints: list[Any], field: str, said: str
) -> None:
    r = await client.post("/maps", json={"grid": GRID.tolist()})
    body = {"map_id": r.json()["map_id"], "start": [0, 0], "goal": [7, 15], "waypoints": waypoints}
    r = await client.post("/plan", json=body)
    assert r.status_code == 422, r.text
    answer = r.json()
    assert answer["field"].startswith(field), answer
    assert said in answer["detail"], answer


async def test_an_unreachable_or_too_near_waypoint_is_422_naming_it(
    client: httpx.AsyncClient,
) -> None:
    walled = [[0, 0, 1, 0, 0], [0, 0, 1, 0, 0], [1, 1, 1, 0, 0]]
    map_id = (await client.post("/maps", json={"grid": walled})).json()["map_id"]
    body = {"map_id": map_id, "start": [0, 0], "goal": [1, 1], "waypoints": [[1, 0], [0, 4]]}
    r = await client.post("/plan", json=body)
    assert r.status_code == 422, r.text
    answer = r.json()
    assert (answer["code"], answer["field"]) == ("NO_VALID_PATH", "waypoints[1]")
    assert "waypoints[1] [0, 4] cannot be reached" in answer["detail"]
    framed = {"grid": GRID.tolist(), "resolution": 0.1}
    map_id = (await client.post("/maps", json=framed)).json()["map_id"]
    body = {"map_id": map_id, "start": [0, 0], "goal": [7, 15]}
    near = {**body, "waypoints": [{"x": 0.31, "y": 0.55}]}  # beside the wall of cell [2, 2]
    r = await client.post("/plan", json=near)
    answer = r.json()
    assert (r.status_code, answer["code"], answer["field"]) == (
        422, "WAYPOINT_OCCUPIED", "waypoints[0]"
    )  # fmt: skip


def test_the_client_sends_waypoints() -> None:
    seen: list[dict[str, Any]] = []

    def handler(request: httpx.Request) -> httpx.Response:
        seen.append(json.loads(request.content))
        return httpx.Response(201, json=schemas.PlanPublic.model_json_schema()["examples"][0])

    waypoints: list[Any] = [(1, 2), {"x": 1.5, "y": 2.5, "yaw": 0.5}]
    with PlannerClient("http://planner", transport=httpx.MockTransport(handler)) as client:
        client.plan("m", [0, 0], [4, 5], waypoints=waypoints)
    assert seen[0]["waypoints"] == [[1, 2], {"x": 1.5, "y": 2.5, "yaw": 0.5}]


async def test_a_route_through_waypoints_keeps_to_max_detour_over_http(
    client: httpx.AsyncClient,
) -> None:
    """The route as a whole within ``max_detour`` times the shortest through the same waypoint,
    as the planner plans it; the preview says what was given up, and the robot steps it."""
    from tests.planner.test_detour import GOAL, START, fence

    robot_map, via = fence(), [{"x": 4.5, "y": 5.0}]
    r = await client.post("/maps", json={"occupancy_grid": robot_map.to_occupancy_grid()})
    assert r.status_code in (200, 201), r.text
    body = {
        "map_id": r.json()["map_id"], "start": START, "goal": GOAL, "waypoints": via,
        "robot_radius": RADIUS, "params": {"max_detour": 1.3},
    }  # fmt: skip
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    plan = r.json()
    detour = plan["preview"]["detour"]
    assert detour["ratio"] <= 1.3 + 1e-9
    assert detour["width_kept"] < 1
    assert plan["params"]["wide_weight"] == 80.0 * detour["width_kept"]
    same = planner.plan(robot_map, START, GOAL, waypoints=via, robot_radius=RADIUS)
    assert plan["preview"]["path"] == same.path.tolist()
    assert same.detour is not None
    assert detour["shortest_m"] == pytest.approx(same.detour.shortest * 0.05, abs=1e-6)
    plan_id = plan["plan_id"]
    for seq in range(5):
        r = await client.post(f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": []})
        assert r.status_code == 200, r.text
        assert r.json()["status"] == "moving"

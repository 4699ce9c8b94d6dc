"""``POST /maps/{map_id}/mapf``, ``PATCH /plan/{plan_id}`` and a fleet's bounds: offline MAPF on
a plain grid is the Moving AI problem (checked by the independent validator), a fleet robot gets
a new goal, and bad input gets a clear 4xx or a ``solve.status``, never a 5xx."""

from __future__ import annotations

from typing import Any

import httpx
import numpy as np
import pytest

import planner
from planner.fleets import grid_graph
from tests.naive_mapf import check_solution
from tests.service.conftest import running
from tests.service.test_fleets import SETTINGS, _map, _plan, client, room

pytestmark = pytest.mark.anyio
__all__ = ["client"]  # the fixture, used by name

ROWS = ["." * 12, ".@@@.@@@.@@.", "." * 12, ".@@.@@@.@@@.", "." * 12]


async def test_offline_mapf_on_a_plain_grid_is_the_moving_ai_problem(
    client: httpx.AsyncClient,
) -> None:
    made = await client.post("/maps", json={"rows": ROWS})
    map_id = made.json()["map_id"]
    free = [(r, c) for r, row in enumerate(ROWS) for c, ch in enumerate(row) if ch == "."]
    rng = np.random.default_rng(0)
    picks = rng.permutation(len(free))
    agents = [{"start": list(free[picks[i]]), "goal": list(free[picks[i + 8]])} for i in range(8)]
    answer = await client.post(f"/maps/{map_id}/mapf", json={"agents": agents})
    assert answer.status_code == 200, answer.text
    body = answer.json()
    assert body["solved"] is True
    graph = grid_graph(np.array([[ch == "." for ch in row] for row in ROWS]))
    paths = np.array([graph.node_of(p) for p in body["paths"]]).T
    starts = graph.node_of([a["start"] for a in agents])
    goals = graph.node_of([a["goal"] for a in agents])
    cost, makespan = check_solution(graph, starts, goals, paths)
    assert (cost, makespan) == (body["sum_of_costs"], body["makespan"])
    assert body["sum_of_costs"] >= body["lower_bound"] > 0


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"agents": []}, "agents"),
        ({"agents": [{"start": [0, 0], "goal": [1, 1]}]}, "agents[0].goal"),
        ({"agents": [{"start": [0, 0], "goal": [0, 99]}]}, "agents[0].goal"),
        ({"agents": [{"start": [0, 0], "goal": [0, 1], "x": 1}]}, "agents[0].x"),
        ({"agents": [{"start": [0, 0], "goal": [0, 1]}], "time_limit_s": 0}, "time_limit_s"),
        ({"agents": [{"start": [0, 0], "goal": [0, 1]}] * 2001}, "agents"),
    ],
)
async def test_offline_mapf_refuses_bad_agents_naming_the_field(
    client: httpx.AsyncClient, body: dict[str, Any], field: str
) -> None:
    map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
    answer = await client.post(f"/maps/{map_id}/mapf", json=body)
    assert answer.status_code == 422, answer.text
    assert field in answer.text


async def test_an_unsolvable_instance_says_so(client: httpx.AsyncClient) -> None:
    map_id = (await client.post("/maps", json={"rows": ["...."]})).json()["map_id"]
    agents = [{"start": [0, 0], "goal": [0, 3]}, {"start": [0, 3], "goal": [0, 0]}]
    answer = await client.post(f"/maps/{map_id}/mapf", json={"agents": agents})
    assert answer.status_code == 200
    assert answer.json()["solved"] is False
    assert answer.json()["status"] in ("unsolvable", "timeout")
    assert (await client.post("/maps/nope/mapf", json={"agents": agents})).status_code == 404


async def test_a_fleet_robot_gets_a_new_goal(client: httpx.AsyncClient) -> None:
    map_id = await _map(client, room(40))
    a = (await _plan(client, map_id, [5, 5], [35, 35], fleet="g")).json()["plan_id"]
    b = (await _plan(client, map_id, [35, 5], [5, 35], fleet="g")).json()["plan_id"]
    for seq in range(3):
        for plan_id in (a, b):
            assert (
                await client.post(f"/plan/{plan_id}/step", json={"seq": seq})
            ).status_code == 200
    taken = await client.patch(f"/plan/{a}", json={"goal": [5, 34]})
    assert taken.status_code == 422
    assert taken.json()["code"] == "FLEET_GOAL_TAKEN"
    walled = await client.patch(f"/plan/{a}", json={"goal": [0, 0]})
    assert walled.status_code == 422
    assert walled.json()["field"] == "goal"
    moved = await client.patch(f"/plan/{a}", json={"goal": [35, 20]})
    assert moved.status_code == 200, moved.text
    assert moved.json()["goal"] == [35, 20]
    assert (await client.get("/fleets/g")).json()["solve"]["status"] == "solved"
    status = ""
    for seq in range(3, 200):
        answer = (await client.post(f"/plan/{a}/step", json={"seq": seq})).json()
        await client.post(f"/plan/{b}/step", json={"seq": seq})
        status = answer["status"]
        if status == "arrived":
            break
    assert status == "arrived"
    robot = next(r for r in (await client.get("/fleets/g")).json()["robots"] if r["plan_id"] == a)
    assert robot["goal"] == [35, 20]
    gx, gy = robot["goal_node"]
    assert (gx - 35) ** 2 + (gy - 20) ** 2 <= 10**2
    lone = (await _plan(client, map_id, [20, 5], [20, 30])).json()["plan_id"]
    refused = await client.patch(f"/plan/{lone}", json={"goal": [25, 30]})
    assert refused.status_code == 422
    assert "no fleet" in refused.json()["detail"]


async def test_a_fleet_is_bounded_in_robots() -> None:
    from service.main import create_app

    app = create_app(SETTINGS.model_copy(update={"max_fleet_robots": 3}))
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://s") as c:
            map_id = await _map(c, room(40))
            for i in range(3):
                made = await _plan(c, map_id, [5 + 8 * i, 5], [5 + 8 * i, 35], fleet="full")
                assert made.status_code == 201, made.text
            over = await _plan(c, map_id, [35, 20], [30, 20], fleet="full")
            assert over.status_code == 422
            assert over.json()["code"] == "FLEET_FULL"


def test_the_table_bound_names_the_field() -> None:
    from service.resources.mapf_size import MAX_TABLE_ENTRIES, check_size

    graph = grid_graph(np.ones((100, 100), dtype=bool))
    check_size(MAX_TABLE_ENTRIES // graph.nodes, graph, "agents")
    with pytest.raises(planner.InvalidInput, match="at most") as error:
        check_size(MAX_TABLE_ENTRIES // graph.nodes + 1, graph, "agents")
    assert error.value.field == "agents"


async def test_an_unsolvable_fleet_says_so_and_its_robots_wait(client: httpx.AsyncClient) -> None:
    # Two robots swapping ends of a one-cell-wide line: no plan exists.
    map_id = (await client.post("/maps", json={"rows": ["....."]})).json()["map_id"]
    body = {"map_id": map_id, "fleet": "line"}
    a = (await client.post("/plan", json={**body, "start": [0, 0], "goal": [0, 4]})).json()
    b = (await client.post("/plan", json={**body, "start": [0, 4], "goal": [0, 0]})).json()
    # The first robot's plan (made when it joined alone) is kept: it may go on, but never onto
    # the second robot, which waits where it is, outside any plan.
    for seq in range(6):
        for plan in (a, b):
            step = await client.post(f"/plan/{plan['plan_id']}/step", json={"seq": seq})
            assert step.status_code == 200, step.text
            if plan is b:
                assert step.json()["status"] == "waiting"
                assert step.json()["position"] == b["start"]
            else:
                assert step.json()["position"] != b["start"]
    fleet = (await client.get("/fleets/line")).json()
    assert fleet["solve"]["status"] in ("unsolvable", "timeout")

"""A plan's optional ``name``: kept with the plan, in every answer, shown by the viewer; a bad
one is a ``422`` naming ``name``."""

from __future__ import annotations

import httpx
import pytest

ROOM = {"rows": ["......", "......", "..@@..", "......", "......"]}


@pytest.mark.anyio
async def test_a_plan_keeps_its_name(client: httpx.AsyncClient) -> None:
    map_id = (await client.post("/maps", json=ROOM)).json()["map_id"]
    body = {"map_id": map_id, "start": [0, 0], "goal": [4, 5], "name": "forklift 3"}
    created = await client.post("/plan", json=body)
    assert created.status_code == 201, created.text
    assert created.json()["name"] == "forklift 3"
    plan_id = created.json()["plan_id"]
    assert (await client.get(f"/plan/{plan_id}")).json()["name"] == "forklift 3"
    page = (await client.get(f"/plan/{plan_id}/view")).text
    assert '"name":"forklift 3"' in page
    unnamed = await client.post("/plan", json={**body, "name": None})
    assert unnamed.json()["name"] is None
    uploaded = await client.post(
        "/maps", json={**ROOM, "start": [0, 0], "goal": [4, 5], "name": "b"}
    )
    assert uploaded.json()["plan"]["name"] == "b"


@pytest.mark.anyio
@pytest.mark.parametrize("name", ["", "x" * 65, 3])
async def test_a_bad_name_is_refused_by_its_field(client: httpx.AsyncClient, name: object) -> None:
    map_id = (await client.post("/maps", json=ROOM)).json()["map_id"]
    body = {"map_id": map_id, "start": [0, 0], "goal": [4, 5], "name": name}
    r = await client.post("/plan", json=body)
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "name"


@pytest.mark.anyio
async def test_a_name_needs_a_plan_on_upload(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={**ROOM, "name": "lonely"})
    assert r.status_code == 422, r.text
    assert "name" in r.json()["detail"]


@pytest.mark.anyio
async def test_a_fleet_robot_is_named_by_its_plan(client: httpx.AsyncClient) -> None:
    map_id = (await client.post("/maps", json=ROOM)).json()["map_id"]
    body = {"map_id": map_id, "start": [0, 0], "goal": [4, 5], "fleet": "hall", "name": "amr-7"}
    assert (await client.post("/plan", json=body)).status_code == 201
    other = {**body, "start": [4, 0], "goal": [0, 5], "name": None}
    assert (await client.post("/plan", json=other)).status_code == 201
    robots = (await client.get("/fleets/hall")).json()["robots"]
    assert [robot["name"] for robot in robots] == ["amr-7", None]

"""The trajectory log beside each plan record, in both stores, and a record that stays small."""

from __future__ import annotations

from collections.abc import AsyncIterator

import httpx
import orjson
import pytest
from fastapi import FastAPI

from service.stores import MemoryStore, RedisStore, Store
from tests.service.conftest import RedisServer

pytestmark = pytest.mark.anyio


@pytest.fixture(params=["memory", "redis"])
async def store(request: pytest.FixtureRequest) -> AsyncIterator[Store]:
    if request.param == "memory":
        yield MemoryStore(ttl_seconds=60)
        return
    server: RedisServer = request.getfixturevalue("redis_server")
    s = RedisStore(server.url, ttl_seconds=60)
    try:
        yield s
    finally:
        await s.close()


async def test_trajectory_is_appended_in_order_with_the_record(store: Store) -> None:
    assert await store.get_trajectory("p") == []
    await store.put_plan("p", {"state": {"iteration": 0}}, append=[(0, 0)])
    await store.put_plan("p", {"state": {"iteration": 1}}, append=[[0, 1], [1, 2]])
    await store.put_plan("p", {"state": {"iteration": 2}})  # a retry: nothing moved
    await store.put_plan("q", {"state": {}}, append=[(9, 9)])
    assert await store.get_trajectory("p") == [(0, 0), (0, 1), (1, 2)]
    assert await store.get_plan("p") == {"state": {"iteration": 2}}
    assert await store.delete_plan("p") is True
    assert await store.get_trajectory("p") == []
    assert await store.get_trajectory("q") == [(9, 9)]


async def test_memory_log_expires_with_its_plan() -> None:
    now = [0.0]
    store = MemoryStore(ttl_seconds=10, clock=lambda: now[0])
    await store.put_plan("p", {}, append=[(1, 1)])
    now[0] = 11.0
    assert await store.get_plan("p") is None
    assert await store.get_trajectory("p") == []


async def test_a_long_episode_keeps_a_small_record(app: FastAPI, client: httpx.AsyncClient) -> None:
    body = {"grid": [[0] * 60] * 60, "start": [0, 0], "goal": [59, 59], "preset": "shortest"}
    plan_id = (await client.post("/maps", json=body)).json()["plan"]["plan_id"]
    store = app.state.engine.store
    sizes = []
    for seq in range(50):
        r = await client.post(f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": []})
        assert r.status_code == 200
        record = await store.get_plan(plan_id)
        assert "trajectory" not in record["state"]
        sizes.append(len(orjson.dumps(record)))
    assert max(sizes) - min(sizes) < 40  # numbers grow a digit or two, the record does not
    detail = (await client.get(f"/plan/{plan_id}")).json()
    assert len(detail["trajectory"]) == 51
    assert detail["trajectory"][0] == [0, 0]
    assert detail["trajectory"][-1] == detail["position"]

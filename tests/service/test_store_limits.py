"""What the store holds decides, on every replica: plans are refused on maps the store no longer
has (404 naming the map: after an eviction, a Redis restart, the memory store's TTL), and so are
steps, pictures and reads of plans whose map is gone; a key holds at most
``PLANNER_MAX_PLANS_PER_TENANT`` live plans (429 ``TOO_MANY_PLANS``, counted atomically across
replicas with Redis); ``/metrics`` moves the same for another key's map id as for an unknown one.
"""

from __future__ import annotations

import asyncio
import re
import time
from collections.abc import AsyncIterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import asynccontextmanager
from pathlib import Path

import httpx
import numpy as np
import pytest
import redis
from pydantic import SecretStr

import planner
from service.client.errors import TooManyRequestsError, raise_for
from service.config import Settings
from service.errors import InsufficientStorage
from service.main import create_app
from service.stores import MemoryStore
from tests.service.conftest import SMALL, RedisServer, replicas, running

ROWS = ["......", ".@@...", "......", "...@..", "......"]
PLAN = {"start": [0, 0], "goal": [4, 5]}


@asynccontextmanager
async def serving(settings: Settings) -> AsyncIterator[httpx.AsyncClient]:
    app = create_app(settings)
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            yield c


def _gone(r: httpx.Response, map_id: str) -> None:
    """A 404 naming the map."""
    assert r.status_code == 404, r.text
    assert r.json()["field"] == "map_id"
    assert map_id in r.json()["detail"]


def _every_use(client: httpx.Client, map_id: str, plan_id: str) -> None:
    """Plan, step, read, draw, stream: each a 404 naming the map."""
    _gone(client.post("/plan", json={"map_id": map_id, **PLAN}), map_id)
    _gone(client.post(f"/plan/{plan_id}/step", json={}), map_id)
    for what in ("", "/render.png", "/path", "/view", "/events"):
        _gone(client.get(f"/plan/{plan_id}{what}"), map_id)


def test_plans_on_a_map_redis_lost_are_404_on_both_replicas(
    redis_server: RedisServer, tmp_path: Path
) -> None:
    """Both replicas have the map's analysis cached and the plan built; the map leaves Redis
    (evicted, as by ``allkeys-lru``): a new plan, a step, a read, a picture are a 404 naming
    the map on both. Then Redis restarts empty: a new plan is a 404 on both too."""
    with (
        replicas(redis_server.url, tmp_path, 2) as (one, two),
        httpx.Client(base_url=one.url, trust_env=False, timeout=30) as a,
        httpx.Client(base_url=two.url, trust_env=False, timeout=30) as b,
    ):
        r = a.post("/maps", json={"rows": ROWS, **PLAN})
        map_id, plan_id = r.json()["map_id"], r.json()["plan"]["plan_id"]
        for client in (a, b):  # warm on both: the analysis, the plan, the map's plainness
            assert client.post("/plan", json={"map_id": map_id, **PLAN}).status_code == 201
            assert client.post(f"/plan/{plan_id}/step", json={}).status_code == 200
        redis.Redis.from_url(redis_server.url).delete(f"planner:map:{map_id}")
        for client in (a, b):
            _every_use(client, map_id, plan_id)
        assert a.delete(f"/plan/{plan_id}").status_code == 204  # forgetting it still works

        assert a.post("/maps", json={"rows": ROWS}).status_code == 201
        for client in (a, b):
            assert client.post("/plan", json={"map_id": map_id, **PLAN}).status_code == 201
        redis_server.stop()
        redis_server.start()  # empty: not persistent
        for client in (a, b):
            deadline = time.monotonic() + 10
            while (r := client.post("/plan", json={"map_id": map_id, **PLAN})).status_code == 503:
                assert time.monotonic() < deadline, r.text  # reconnecting
                time.sleep(0.1)
            _gone(r, map_id)


@pytest.mark.anyio
async def test_a_plan_on_a_map_evicted_after_its_plans_expired_is_404() -> None:
    """The memory store: the map's plan expires (``PLANNER_PLAN_TTL_SECONDS``), another map
    evicts it (``PLANNER_MAP_STORE_BYTES``); its analysis is still cached, yet a new plan on it
    is a 404 naming the map, as ``GET /maps/{map_id}`` is."""
    settings = SMALL.model_copy(update={"plan_ttl_seconds": 0.3, "map_store_bytes": 3000})
    async with serving(settings) as client:
        rows = ["." * 30] * 30
        r = await client.post("/maps", json={"rows": rows, "start": [0, 0], "goal": [29, 29]})
        map_id = r.json()["map_id"]
        await asyncio.sleep(0.5)  # its plan expires: nothing holds the map any more
        other = await client.post("/maps", json={"rows": ["." * 29 + "@"] * 30})
        assert other.status_code == 201
        assert (await client.get(f"/maps/{map_id}")).status_code == 404
        plan = {"map_id": map_id, "start": [0, 0], "goal": [29, 29]}
        _gone(await client.post("/plan", json=plan), map_id)


@pytest.mark.anyio
async def test_a_key_holds_at_most_its_plans_on_the_memory_store() -> None:
    settings = SMALL.model_copy(
        update={"max_plans_per_tenant": 3, "api_keys": SecretStr("ka,kb"), "plan_ttl_seconds": 1}
    )
    a, b = {"X-API-Key": "ka"}, {"X-API-Key": "kb"}
    async with serving(settings) as client:
        map_id = (await client.post("/maps", json={"rows": ROWS}, headers=a)).json()["map_id"]
        assert (await client.post("/maps", json={"rows": ROWS}, headers=b)).status_code == 201
        body = {"map_id": map_id, **PLAN}
        plans = [(await client.post("/plan", json=body, headers=a)).json() for _ in range(3)]
        r = await client.post("/plan", json=body, headers=a)
        assert r.status_code == 429, r.text
        assert r.json()["code"] == "TOO_MANY_PLANS"
        assert "PLANNER_MAX_PLANS_PER_TENANT" in r.json()["detail"]
        with pytest.raises(TooManyRequestsError):  # the Python client's name for it
            raise_for(r)
        # With a start and a goal, an upload plans too: refused alike.
        upload = await client.post("/maps", json={"rows": ROWS, **PLAN}, headers=a)
        assert upload.status_code == 429
        assert (await client.post("/plan", json=body, headers=b)).status_code == 201
        assert (await client.delete(f"/plan/{plans[0]['plan_id']}", headers=a)).status_code == 204
        assert (await client.post("/plan", json=body, headers=a)).status_code == 201
        assert (await client.post("/plan", json=body, headers=a)).status_code == 429
        await asyncio.sleep(1.2)  # expired: their places are free
        for _ in range(3):
            assert (await client.post("/plan", json=body, headers=a)).status_code == 201


def test_a_key_holds_at_most_its_plans_across_redis_replicas(
    redis_server: RedisServer, tmp_path: Path
) -> None:
    """Cap 5: 12 plans asked at once on two replicas, exactly 5 made; a deleted plan frees its
    place; a plan kept alive by its steps keeps its place past the TTL it was created with,
    while the others' places are freed by their expiry."""
    env = {"PLANNER_MAX_PLANS_PER_TENANT": "5", "PLANNER_PLAN_TTL_SECONDS": "2"}
    with (
        replicas(redis_server.url, tmp_path, 2, env) as (one, two),
        httpx.Client(base_url=one.url, trust_env=False, timeout=30) as a,
        httpx.Client(base_url=two.url, trust_env=False, timeout=30) as b,
    ):
        map_id = a.post("/maps", json={"rows": ROWS}).json()["map_id"]
        body = {"map_id": map_id, **PLAN}
        for client in (a, b):  # warm: the race is the store's, not the analyses'
            r = client.post("/plan", json=body)
            assert client.delete(f"/plan/{r.json()['plan_id']}").status_code == 204

        def create(i: int) -> httpx.Response:
            return (a if i % 2 else b).post("/plan", json=body)

        with ThreadPoolExecutor(12) as threads:
            answers = list(threads.map(create, range(12)))
        made = [r.json()["plan_id"] for r in answers if r.status_code == 201]
        assert len(made) == 5, [r.status_code for r in answers]
        assert {r.json()["code"] for r in answers if r.status_code != 201} == {"TOO_MANY_PLANS"}
        assert b.delete(f"/plan/{made.pop()}").status_code == 204
        r = a.post("/plan", json=body)
        assert r.status_code == 201
        kept = r.json()["plan_id"]
        assert b.post("/plan", json=body).status_code == 429
        # 3 s of steps on one plan: the others expire, it does not.
        deadline = time.monotonic() + 3
        while time.monotonic() < deadline:
            assert b.post(f"/plan/{kept}/step", json={}).status_code == 200
            time.sleep(0.3)
        statuses = [a.post("/plan", json=body).status_code for _ in range(5)]
        assert statuses == [201, 201, 201, 201, 429]


def _figures(text: str) -> dict[str, float]:
    """Every sample of a scrape but the durations' (time, not counts)."""
    out = {}
    for line in text.splitlines():
        if line.startswith("#") or "duration_seconds" in line:
            continue
        name, _, value = line.rpartition(" ")
        out[name] = float(value)
    return out


@pytest.mark.anyio
async def test_metrics_move_alike_for_another_keys_map_and_an_unknown_one() -> None:
    """Key B's map, planned on and drawn by B; key A asks for it, then for an id nobody has,
    by every map route, 6 times: each scrape moves every figure the same for both."""
    settings = SMALL.model_copy(update={"api_keys": SecretStr("ka,kb")})
    a, b = {"X-API-Key": "ka"}, {"X-API-Key": "kb"}
    async with serving(settings) as client:
        r = await client.post("/maps", json={"rows": ROWS, **PLAN}, headers=b)
        theirs = r.json()["map_id"]
        assert (await client.get(f"/maps/{theirs}/render.png", headers=b)).status_code == 200
        unknown = re.sub("[0-9a-f]", "7", theirs)

        async def moved(map_id: str) -> dict[str, float]:
            before = _figures((await client.get("/metrics")).text)
            asks = [
                client.post("/plan", json={"map_id": map_id, **PLAN}, headers=a),
                client.get(f"/maps/{map_id}", headers=a),
                client.get(f"/maps/{map_id}/render.png", headers=a),
                client.post(f"/maps/{map_id}/simulate", json=PLAN, headers=a),
            ]
            for ask in asks:
                assert (await ask).status_code == 404
            after = _figures((await client.get("/metrics")).text)
            return {k: v - before.get(k, 0.0) for k, v in after.items() if v != before.get(k)}

        for _ in range(6):
            assert await moved(theirs) == await moved(unknown)


@pytest.mark.anyio
async def test_tiny_maps_count_their_bookkeeping_against_the_map_store_bound() -> None:
    """3 x 3 maps take ~760 bytes each in memory, not 9: 64 KiB of store holds at most 64 of
    them (older idle ones evicted), and refuses a new one when live plans hold them all."""
    store = MemoryStore(ttl_seconds=60, max_map_bytes=64 * 1024)
    tiny = [planner.grid_map(np.array([[(i >> k) & 1 for k in range(3)], [0] * 3, [0] * 3],
                                      dtype=np.uint8), resolution=1 + i / 1000)
            for i in range(200)]  # fmt: skip
    for i, robot_map in enumerate(tiny):
        assert await store.put_map(f"m{i}", robot_map)
    maps, _ = await store.counts()
    assert 0 < maps <= 64
    assert store.map_bytes <= 64 * 1024
    for i in range(200 - maps, 200):
        await store.put_plan(f"p{i}", {"map_id": f"m{i}"})
    with pytest.raises(InsufficientStorage):
        await store.put_map("one-more", tiny[0])

"""Issue 13 over ASGI: bodies nested too deep, small error bodies, plans that stay deleted, no
lock left behind, a bounded map store, capped and stoppable simulations, per-route body limits,
API keys and tenants, per-tenant cache shares."""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import httpx
import numpy as np
import pytest
import redis.asyncio as redis
from pydantic import SecretStr
from starlette.types import Message

import planner
from service.config import Settings
from service.edge.guards import MAX_JSON_DEPTH, json_depth
from service.errors import Busy, InsufficientStorage
from service.main import create_app
from service.stores import MemoryStore
from service.stores.memory import MAP_OVERHEAD_BYTES
from service.tenants import TENANT
from service.work.cache import ByteLRU
from service.work.pool import Pool
from tests.service.conftest import SMALL, RedisServer, random_map, running

pytestmark = pytest.mark.anyio

ROWS = ["......", ".@@...", "......", "...@..", "......"]


@asynccontextmanager
async def serving(settings: Settings) -> AsyncIterator[httpx.AsyncClient]:
    app = create_app(settings)
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            c.app = app  # type: ignore[attr-defined]
            yield c


async def _plan(client: httpx.AsyncClient, **headers: str) -> tuple[str, str]:
    body = {"rows": ROWS, "start": [0, 0], "goal": [4, 5]}
    r = await client.post("/maps", json=body, headers=headers)
    assert r.status_code in (200, 201), r.text
    return r.json()["map_id"], r.json()["plan"]["plan_id"]


def test_json_depth_counts_brackets_outside_strings() -> None:
    assert json_depth(b"[" * 10 + b"]" * 10) == 10
    assert json_depth(b'{"a": "[[[[[[", "b": [{"c": "\\"[["}]}') == 3
    assert json_depth(b'["\\\\", [[1]]]') == 3


@pytest.mark.parametrize(
    ("method", "url"),
    [
        ("POST", "/maps"),
        ("POST", "/plan"),
        ("POST", "/plan/{plan}/step"),
        ("POST", "/maps/{map}/simulate"),
    ],
)
async def test_deep_nesting_is_refused_unparsed_on_every_post_route(
    client: httpx.AsyncClient, method: str, url: str
) -> None:
    map_id, plan_id = await _plan(client)
    url = url.format(map=map_id, plan=plan_id)
    for depth in (MAX_JSON_DEPTH + 1, 1000, 5000):  # 1000: a RecursionError (500) before
        body = b'{"x": ' + b"[" * depth + b"]" * depth + b"}"
        r = await client.request(method, url, content=body)
        assert r.status_code == 422, r.text
        assert f"nests {depth + 1} levels deep; the limit is {MAX_JSON_DEPTH}" in r.json()["detail"]
    # Deep but within the limit: the model refuses it, with a short message.
    body = b'{"dynamic_obstacles": ' + b"[" * 60 + b"]" * 60 + b"}"
    r = await client.post(f"/plan/{plan_id}/step", content=body)
    assert r.status_code == 422
    assert len(r.content) < 1000


async def test_error_bodies_stay_small_whatever_was_sent(client: httpx.AsyncClient) -> None:
    huge = "x" * 200_000
    map_id, plan_id = await _plan(client)
    answers = [
        await client.get(f"/plan/{huge[:16000]}"),
        await client.delete(f"/plan/{huge[:16000]}"),
        await client.post(f"/plan/{huge[:16000]}/step", json={}),
        await client.get(f"/maps/{huge[:16000]}"),
        await client.get(f"/maps/{huge[:16000]}/render.png"),
        await client.post("/plan", json={"map_id": huge[:60000], "start": [0, 0], "goal": [1, 1]}),
        await client.post("/plan", json={huge[:60000]: 1}),
        await client.post(f"/plan/{plan_id}/step", json={"seq": huge[:60000]}),
        await client.get(f"/maps/{map_id}/render.png", params={"preset": huge[:16000]}),
        await client.get(f"/maps/{map_id}/render.png", params={"cell": huge[:16000]}),
    ]
    for r in answers:
        assert 400 <= r.status_code < 500, r.text[:200]
        assert len(r.content) < 1500, (r.status_code, r.text[:200])


async def test_a_deleted_plan_stays_deleted_whatever_step_was_in_flight(
    client: httpx.AsyncClient,
) -> None:
    engine = client._transport.app.state.engine  # type: ignore[attr-defined]
    for trial in range(40):
        _, plan_id = await _plan(client)
        # A step that replans (an obstacle on its next cell), so that it awaits a worker.
        preview = (await client.get(f"/plan/{plan_id}")).json()["preview"]["path"]
        step = asyncio.ensure_future(
            client.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": [preview[1]]})
        )
        if trial % 2:
            await asyncio.sleep(0)  # let the step take its lock first, every other trial
        deleted = await client.delete(f"/plan/{plan_id}")
        stepped = await step
        assert deleted.status_code == 204
        assert stepped.status_code in (200, 404), stepped.text
        assert (await client.get(f"/plan/{plan_id}")).status_code == 404
        again = await client.post(f"/plan/{plan_id}/step", json={})
        assert again.status_code == 404
    assert engine.store.lock_count == 0


async def test_steps_to_unknown_plans_leave_no_lock(client: httpx.AsyncClient) -> None:
    engine = client._transport.app.state.engine  # type: ignore[attr-defined]
    for i in range(50):
        r = await client.post(f"/plan/{'u' * 1000}{i}/step", json={"dynamic_obstacles": []})
        assert r.status_code == 404
    _, plan_id = await _plan(client)
    assert (await client.post(f"/plan/{plan_id}/step", json={"seq": 0})).status_code == 200
    assert (await client.post(f"/plan/{plan_id}/step", json={"seq": 9})).status_code == 409
    assert engine.store.lock_count == 0  # released on the error path too


MIB_MAP = 1024 * 1024 + MAP_OVERHEAD_BYTES
"""What a 1024 x 1024 map takes of the memory store's bound."""


async def test_the_memory_map_store_evicts_idle_maps_and_refuses_when_plans_hold_it() -> None:
    store = MemoryStore(ttl_seconds=60, max_map_bytes=4 * MIB_MAP)
    grids = [planner.grid_map(random_map(1024, 1024, 0.2, seed)) for seed in range(6)]
    for i, grid in enumerate(grids[:4]):
        assert await store.put_map(f"m{i}", grid)
    assert store.map_bytes == 4 * MIB_MAP
    await store.get_map("m0")  # used: now the most recent
    await store.put_plan("p", {"map_id": "m1"})  # m1 has a live plan
    assert await store.put_map("m4", grids[4])  # evicts m2, the least recently used idle map
    assert await store.get_map("m2") is None
    assert await store.get_map("m0") is not None
    assert await store.get_map("m1") is not None
    await store.put_plan("q", {"map_id": "m0"})
    await store.put_plan("r", {"map_id": "m3"})
    await store.put_plan("s", {"map_id": "m4"})
    with pytest.raises(InsufficientStorage, match="PLANNER_MAP_STORE_BYTES") as caught:
        await store.put_map("m5", grids[5])
    assert caught.value.status == 507
    assert await store.delete_plan("q")
    assert await store.put_map("m5", grids[5])  # m0 is idle again: evicted
    assert await store.get_map("m0") is None
    assert store.map_bytes <= 4 * MIB_MAP


async def test_a_full_map_store_answers_507() -> None:
    settings = SMALL.model_copy(update={"map_store_bytes": 4096, "max_map_cells": 10_000})
    async with serving(settings) as client:
        body = {"grid": random_map(40, 40, 0.2, 1).tolist(), "start": [0, 0], "goal": [39, 39]}
        assert (await client.post("/maps", json=body)).status_code == 201
        r = await client.post("/maps", json={"grid": random_map(40, 40, 0.2, 2).tolist()})
        assert r.status_code == 507, r.text
        assert r.json()["code"] == "STORE_FULL"


def serpentine(height: int, width: int) -> list[str]:
    """A corridor two cells wide winding across the map: the path is ~height * width / 3."""
    rows = []
    for r in range(height):
        if r % 3 != 2:
            rows.append("." * width)
        elif (r // 3) % 2 == 0:
            rows.append("@" * (width - 2) + "..")
        else:
            rows.append(".." + "@" * (width - 2))
    return rows


async def test_simulation_steps_are_capped_and_a_long_one_is_stopped() -> None:
    settings = SMALL.model_copy(
        update={
            "max_simulation_steps": 500_000,
            "request_timeout_seconds": 0.3,
            "max_map_cells": 100_000,
            "max_body_bytes": 1 << 20,
        }
    )
    async with serving(settings) as client:
        for _ in range(20):  # the upload too must fit in 0.3 s, however busy the machine
            r = await client.post("/maps", json={"rows": serpentine(301, 300)})
            if r.status_code in (200, 201):
                break
        map_id = r.json()["map_id"]
        body = {"start": [0, 0], "goal": [300, 299], "max_steps": 500_001, "preset": "shortest"}
        r = await client.post(f"/maps/{map_id}/simulate", json=body)
        assert r.status_code == 422
        assert "PLANNER_MAX_SIMULATION_STEPS" in r.json()["detail"]
        # The analysis and waves first, into the cache (they run to the end even after a 504),
        # so that what the timeout stops below is the episode itself, however busy the machine.
        for _ in range(20):
            warm = await client.post(f"/maps/{map_id}/simulate", json={**body, "max_steps": 1})
            if warm.status_code == 200:
                break
        assert warm.status_code == 200, warm.text
        # ~30,000 steps (about a second): stopped at 0.3 s.
        body = {**body, "max_steps": 500_000}
        t0 = time.monotonic()
        r = await client.post(f"/maps/{map_id}/simulate", json=body)
        elapsed = time.monotonic() - t0
        assert r.status_code == 504, r.text
        assert "PLANNER_REQUEST_TIMEOUT_SECONDS" in r.json()["detail"]
        assert elapsed < 1.5
        engine = client.app.state.engine  # type: ignore[attr-defined]
        for _ in range(400):  # the worker is free again soon after: the episode stopped
            if engine.pool.busy == 0:
                break
            await asyncio.sleep(0.005)
        assert engine.pool.busy == 0


async def test_only_a_map_upload_has_the_large_body_limit() -> None:
    settings = SMALL.model_copy(update={"max_step_body_bytes": 4096})
    async with serving(settings) as client:
        map_id, plan_id = await _plan(client)
        big = {"dynamic_obstacles": [[4, 4]] * 1000}
        r = await client.post(f"/plan/{plan_id}/step", json=big)
        assert r.status_code == 413
        assert "PLANNER_MAX_STEP_BODY_BYTES is 4096" in r.json()["detail"]
        for url, body in [
            ("/plan", {"map_id": "x" * 5000, "start": [0, 0], "goal": [0, 1]}),
            (f"/maps/{map_id}/simulate", {"start": [0, 0], "goal": [0, 1], "preset": "x" * 5000}),
        ]:
            r = await client.post(url, json=body)
            assert r.status_code == 413, url
            assert "PLANNER_MAX_STEP_BODY_BYTES is 4096" in r.json()["detail"]
        r = await client.post("/maps", json={"rows": ["." * 64] * 64})  # over 4096 bytes
        assert r.status_code in (200, 201), r.text


async def test_api_keys_guard_every_endpoint_but_the_open_ones_and_split_tenants() -> None:
    settings = SMALL.model_copy(update={"api_keys": SecretStr("alpha-key, beta-key")})
    assert "alpha" not in repr(settings)
    async with serving(settings) as client:
        for method, url in [("POST", "/maps"), ("GET", "/plan/x"), ("POST", "/plan/x/step")]:
            r = await client.request(method, url, json={})
            assert r.status_code == 401
            assert r.headers["www-authenticate"].startswith("Bearer")
            assert r.json()["code"] == "UNAUTHORIZED"
        bad = await client.get("/plan/x", headers={"Authorization": "Bearer alpha-ke"})
        assert bad.status_code == 401
        for url in ["/healthz", "/openapi.json", "/docs"]:
            assert (await client.get(url)).status_code == 200
        a = {"Authorization": "Bearer alpha-key"}
        b = {"X-API-Key": "beta-key"}
        map_id, plan_id = await _plan(client, **a)
        assert (await client.get(f"/plan/{plan_id}", headers=a)).status_code == 200
        assert (await client.get(f"/plan/{plan_id}", headers=b)).status_code == 404
        assert (await client.post(f"/plan/{plan_id}/step", headers=b, json={})).status_code == 404
        assert (await client.delete(f"/plan/{plan_id}", headers=b)).status_code == 404
        assert (await client.get(f"/maps/{map_id}", headers=b)).status_code == 404
        assert (await client.get(f"/plan/{plan_id}", headers=a)).status_code == 200
        # The same map uploaded by B is B's own, with the same content-hash id.
        again = await client.post("/maps", json={"rows": ROWS}, headers=b)
        assert again.status_code == 201
        assert again.json()["map_id"] == map_id
        health = (await client.get("/healthz")).text
        assert "alpha" not in health
        assert "beta" not in health


async def test_one_tenant_cannot_evict_another_tenants_cache_entries() -> None:
    cache = ByteLRU(max_bytes=1000, shares=2)

    async def put(tenant: str, key: str) -> None:
        TENANT.set(tenant)

        async def compute() -> np.ndarray:
            return np.zeros(200, dtype=np.uint8)

        await cache.get_or_compute(key, compute)

    await put("a", "a0")
    await put("a", "a1")
    for i in range(20):  # b thrashes the cache
        await put("b", f"b{i}")
    TENANT.set("")
    assert cache.peek("a0") is not None
    assert cache.peek("a1") is not None
    assert cache.bytes <= 1000


async def test_a_picture_over_the_pixel_limit_is_refused_naming_it() -> None:
    settings = SMALL.model_copy(update={"max_map_cells": 100_000, "max_body_bytes": 1 << 20})
    async with serving(settings) as client:
        map_id = (await client.post("/maps", json={"rows": serpentine(300, 300)})).json()["map_id"]
        r = await client.get(f"/maps/{map_id}/render.png", params={"cell": 16})
        assert r.status_code == 413
        assert "the limit is 16777216 (use cell <= 13)" in r.json()["detail"]
        r = await client.get(f"/maps/{map_id}/render.png", params={"cell": 13})
        assert r.status_code == 200
        assert r.headers["content-type"] == "image/png"


async def test_one_tenant_cannot_evict_another_tenants_maps() -> None:
    store = MemoryStore(ttl_seconds=60, max_map_bytes=4 * MIB_MAP, shares=2)
    grids = [planner.grid_map(random_map(1024, 1024, 0.2, seed)) for seed in range(8)]
    TENANT.set("a")
    for i in range(2):
        assert await store.put_map(f"m{i}", grids[i])
    TENANT.set("b")
    for i in range(2, 8):  # b's own least recently used maps make room for b
        assert await store.put_map(f"m{i}", grids[i])
    assert await store.get_map("m7") is not None
    assert await store.get_map("m2") is None
    await store.put_plan("p", {"map_id": "m6"})
    await store.put_plan("q", {"map_id": "m7"})
    with pytest.raises(InsufficientStorage):  # b's share is held by its live plans
        await store.put_map("m8", planner.grid_map(random_map(1024, 1024, 0.2, 8)))
    TENANT.set("a")
    assert await store.get_map("m0") is not None
    assert await store.get_map("m1") is not None
    TENANT.set("")
    assert store.map_bytes <= 4 * MIB_MAP


async def test_heavy_jobs_beyond_the_queue_are_refused_and_steps_still_run() -> None:
    pool = Pool(1, step_size=1, max_queued=1)
    gate = threading.Event()
    try:
        held = [asyncio.ensure_future(pool.run(gate.wait, 10)) for _ in range(2)]
        await asyncio.sleep(0.05)
        with pytest.raises(Busy, match="PLANNER_MAX_QUEUED_JOBS is 1") as caught:
            await pool.run(time.sleep, 0)
        assert caught.value.status == 503
        assert await pool.run_step(lambda: 42) == 42  # not behind the heavy queue
        gate.set()
        await asyncio.gather(*held)
        assert pool.jobs == 0
    finally:
        gate.set()
        pool.close()


async def test_a_simulation_whose_client_went_away_is_cancelled() -> None:
    settings = SMALL.model_copy(
        update={
            "max_simulation_steps": 500_000,
            "max_map_cells": 100_000,
            "max_body_bytes": 1 << 20,
        }
    )
    app = create_app(settings)
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            r = await client.post("/maps", json={"rows": serpentine(301, 300)})
            map_id = r.json()["map_id"]
            # The analysis and waves first (they are not stopped, and a busy machine may take
            # a while over them): what the hang-up must stop below is the episode.
            warm = {"start": [0, 0], "goal": [300, 299], "max_steps": 1, "preset": "shortest"}
            r = await client.post(f"/maps/{map_id}/simulate", json=warm)
            assert r.status_code == 200, r.text
        body = b'{"start": [0, 0], "goal": [300, 299], "max_steps": 500000, "preset": "shortest"}'
        messages: list[Message] = [{"type": "http.request", "body": body}]
        sent: list[Message] = []

        async def receive() -> Message:
            if messages:
                return messages.pop(0)
            await asyncio.sleep(0.3)  # the client hangs up while the episode runs
            return {"type": "http.disconnect"}

        async def send(message: Message) -> None:
            sent.append(message)

        scope = {
            "type": "http", "http_version": "1.1", "method": "POST", "scheme": "http",
            "path": f"/maps/{map_id}/simulate", "raw_path": b"", "root_path": "",
            "query_string": b"", "server": ("service", 80), "client": ("127.0.0.1", 1),
            "headers": [(b"content-type", b"application/json")], "app": app,
            "state": {},
        }  # fmt: skip
        t0 = time.monotonic()
        await app(scope, receive, send)
        assert time.monotonic() - t0 < 1.0  # a whole episode takes about a second
        assert sent == []  # nobody to answer
        engine = app.state.engine
        for _ in range(200):  # its worker is free again at once: the episode stopped
            if engine.pool.busy == 0:
                break
            await asyncio.sleep(0.005)
        assert engine.pool.busy == 0


def _map_routes(map_id: str) -> list[tuple[str, str, Any]]:
    """A request on each route under ``/maps/{map_id}`` that computes and caches something."""
    return [
        ("GET", f"/maps/{map_id}", None),
        ("GET", f"/maps/{map_id}/render.png", None),
        ("GET", f"/maps/{map_id}/passages?robot_radius=0", None),
        ("POST", f"/maps/{map_id}/simulate", {"start": [0, 0], "goal": [39, 39]}),
        ("POST", f"/maps/{map_id}/mapf", {"agents": [{"start": [0, 0], "goal": [0, 1]}]}),
    ]


async def _answered(client: httpx.AsyncClient, map_id: str, status: int) -> None:
    """Every route of :func:`_map_routes` answers ``status`` (a 404 naming ``map_id``)."""
    for method, path, body in _map_routes(map_id):
        r = await client.request(method, path, json=body)
        assert r.status_code == status, (path, r.text)
        if status == 404:
            assert r.json()["field"] == "map_id"


async def test_every_route_under_a_map_is_404_once_the_map_is_gone() -> None:
    """An idle map evicted from the memory store by a newer one: its cached analysis and
    passages outlive it, but no route answers for it any more (they answered 200)."""
    settings = SMALL.model_copy(update={"map_store_bytes": 4096, "max_map_cells": 10_000})
    async with serving(settings) as client:
        first = {"grid": random_map(40, 40, 0.2, 1).tolist()}
        map_id = (await client.post("/maps", json=first)).json()["map_id"]
        await _answered(client, map_id, 200)  # computed and cached while the map is there
        second = {"grid": random_map(40, 40, 0.2, 2).tolist()}
        assert (await client.post("/maps", json=second)).status_code == 201
        await _answered(client, map_id, 404)


async def test_every_route_under_a_map_is_404_once_it_left_redis(
    redis_server: RedisServer,
) -> None:
    """On the Redis store a map unused for ``PLANNER_MAP_TTL_SECONDS`` leaves Redis; this
    replica's cached analysis and passages outlive it, but no route answers for it any more."""
    settings = SMALL.model_copy(
        update={"store_url": redis_server.url, "map_ttl_seconds": 1.0, "max_map_cells": 10_000}
    )
    async with serving(settings) as client:
        first = {"grid": random_map(40, 40, 0.2, 1).tolist()}
        map_id = (await client.post("/maps", json=first)).json()["map_id"]
        await _answered(client, map_id, 200)
        deadline, watcher = time.monotonic() + 30, redis.Redis.from_url(redis_server.url)
        try:
            while await watcher.exists(f"planner:map:{map_id}"):
                assert time.monotonic() < deadline, "the map never left Redis"
                await asyncio.sleep(0.1)
        finally:
            await watcher.aclose()
        await _answered(client, map_id, 404)

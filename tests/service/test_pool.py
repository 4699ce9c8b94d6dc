"""The pool keeps the event loop free: /healthz answers while four 1024 x 1024 maps analyse."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

import httpx
import pytest

from service.config import Settings
from service.main import create_app
from service.work.engine import Engine
from tests.service.conftest import random_map, running

pytestmark = pytest.mark.anyio


@pytest.fixture
async def big() -> AsyncIterator[tuple[httpx.AsyncClient, Engine]]:
    settings = Settings(pool_size=4)
    app = create_app(settings)
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            yield c, app.state.engine


async def test_healthz_answers_while_four_big_analyses_run(
    big: tuple[httpx.AsyncClient, Engine],
) -> None:
    client, engine = big
    bodies = []
    for seed in range(4):
        grid = random_map(1024, 1024, 0.2, seed)
        r = await client.post("/maps", json={"grid": grid.tolist()})
        assert r.status_code == 201
        bodies.append({"map_id": r.json()["map_id"], "start": [0, 0], "goal": [1023, 1023]})
    misses = engine.cache.misses
    tasks = [asyncio.ensure_future(client.post("/plan", json=b)) for b in bodies]
    while engine.cache.misses - misses < 4:  # all four analyses handed to the pool
        await asyncio.sleep(0.001)
    answers = []
    for _ in range(5):
        answers.append((await client.get("/healthz")).status_code)
    running = [not t.done() for t in tasks]
    plans = await asyncio.gather(*tasks)
    assert answers == [200] * 5
    assert any(running), "the analyses ended before /healthz answered: the loop was blocked"
    assert [p.status_code for p in plans] == [201] * 4
    assert all(p.json()["analysis"]["cache_hit"] is False for p in plans)


@pytest.mark.parametrize("tenants", [True, False])
async def test_one_tenant_flooding_heavy_work_never_holds_every_worker(tenants: bool) -> None:
    """Tenant A sends three 1 s jobs to a pool of two workers, then tenant B a short one: B's
    runs at once (A holds at most one worker), where first come, first served (the control,
    without tenants) makes it wait for A's first job. A's jobs past its share of the queue are
    refused (503)."""
    from service.errors import Busy
    from service.tenants import TENANT
    from service.work.pool import Pool

    pool = Pool(2, max_queued=4, tenants=tenants)
    try:

        async def job(tenant: str, seconds: float) -> float:
            TENANT.set(tenant)
            started = asyncio.get_running_loop().time()
            await pool.run(__import__("time").sleep, seconds)
            return asyncio.get_running_loop().time() - started

        flood = [asyncio.ensure_future(job("a", 1.0)) for _ in range(3)]
        await asyncio.sleep(0.05)
        waited = await job("b", 0.01)
        assert waited < 0.5 if tenants else waited > 0.5
        if tenants:
            more = [asyncio.ensure_future(job("a", 0.01)) for _ in range(3)]
            done = await asyncio.gather(*more, return_exceptions=True)
            assert any(isinstance(d, Busy) for d in done)  # over A's share of the queue
        await asyncio.gather(*flood)
    finally:
        pool.close()

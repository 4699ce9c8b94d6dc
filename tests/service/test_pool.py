"""The pool keeps the event loop free: /healthz answers while four 1024 x 1024 maps analyse."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

import httpx
import pytest

from service.config import Settings
from service.main import create_app
from service.work.engine import Engine
from tests.service.conftest import random_map

pytestmark = pytest.mark.anyio


@pytest.fixture
async def big() -> AsyncIterator[tuple[httpx.AsyncClient, Engine]]:
    settings = Settings(pool_size=4)
    app = create_app(settings)
    async with app.router.lifespan_context(app):
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

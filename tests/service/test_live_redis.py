"""The live layer on Redis (docs/live.md): the same marks as the memory store keeps through
marking, clearing and lapsing, a scan's update in one round trip, and two replicas sharing the
marks: a scan reported to one, a robot stepped on the other plans around it at once."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from redis.asyncio import Redis

import planner
from service.stores import MemoryStore, RedisStore, Store
from service.stores.live import Seen
from service.tenants import TENANT
from tests.service.conftest import RedisServer, Replica, replicas
from tests.service.test_live import BOX, MAP, PLAN, RADIUS, _crosses, _scan


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture
async def redis_store(redis_server: RedisServer) -> AsyncIterator[RedisStore]:
    s = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        yield s
    finally:
        await s.close()


def _seen(marked: list[int], top: int, left: int, cleared: list[list[int]], s: float) -> Seen:
    traced = planner.Traced(
        np.array(marked, dtype=np.int64), top, left, np.array(cleared, dtype=np.uint8)
    )
    return Seen(traced, 10, s)


@pytest.mark.anyio
async def test_redis_keeps_the_marks_the_memory_store_keeps(redis_store: RedisStore) -> None:
    memory = MemoryStore(ttl_seconds=60)
    window = [[1, 1, 0], [1, 1, 1]]  # rows 2-3, cols 4-6 of a 10-wide map
    steps = [
        _seen([11, 12, 25, 99], 2, 4, window, 60),  # 25 is in the window: the mark wins
        _seen([], 2, 4, window, 60),  # clears 24, 25, 34, 35, 36 (none marked but 25)
        _seen([24, 50], 0, 0, [[0]], 0.3),  # lapses soon
    ]
    expected = [[11, 12, 25, 99], [11, 12, 99], [11, 12, 24, 50, 99]]

    async def run(store: Store) -> None:
        for seen, marks in zip(steps, expected, strict=True):
            assert await store.observe("m", seen) == len(marks)
            assert (await store.live_marks("m")).tolist() == marks
        await asyncio.sleep(0.5)
        assert (await store.live_marks("m")).tolist() == [11, 12, 99]
        token = TENANT.set("other")
        try:
            assert (await store.live_marks("m")).tolist() == []
        finally:
            TENANT.reset(token)

    await run(memory)
    await run(redis_store)


@pytest.mark.anyio
async def test_a_scans_update_is_one_round_trip(
    redis_store: RedisStore, redis_server: RedisServer
) -> None:
    seen = _seen(list(range(0, 3000, 3)), 0, 0, np.ones((40, 10), dtype=np.uint8).tolist(), 60)
    await redis_store.observe("m", seen)  # the script loaded
    counter = Redis.from_url(redis_server.url)
    try:
        await counter.config_resetstat()
        await redis_store.observe("m", seen)
        stats = await counter.info("commandstats")
    finally:
        await counter.aclose()
    calls = {name: value["calls"] for name, value in stats.items()}
    # The script and what it runs inside Redis; nothing else came over the wire.
    assert calls.pop("cmdstat_evalsha") == 1
    calls = {k: v for k, v in calls.items() if not k.startswith("cmdstat_config")}
    assert set(calls) <= {"cmdstat_hgetall", "cmdstat_hdel", "cmdstat_hset", "cmdstat_hlen",
                          "cmdstat_pexpire", "cmdstat_pttl", "cmdstat_time"}  # fmt: skip


@pytest.fixture
def two(redis_server: RedisServer, tmp_path: Path) -> Iterator[list[Replica]]:
    with replicas(redis_server.url, tmp_path, 2, {"PLANNER_API_KEYS": "ka,kb"}) as started:
        yield started


def test_a_scan_on_one_replica_is_stepped_around_on_the_other(two: list[Replica]) -> None:
    a, b = (httpx.Client(base_url=r.url, trust_env=False, timeout=60) for r in two)
    key = {"X-API-Key": "ka"}
    with a, b:
        map_id = a.post("/maps", json=MAP, headers=key).json()["map_id"]
        plan_id = b.post("/plan", json={"map_id": map_id, **PLAN}, headers=key).json()["plan_id"]
        first = b.post(f"/plan/{plan_id}/step", json={}, headers=key).json()
        assert _crosses(first["poses"], BOX)
        body: dict[str, Any] = {
            "scan": _scan((1.05, 1.45, 0.0), [BOX]),
            "scan_pose": {"x": 1.05, "y": 1.45, "yaw": 0.0},
        }
        r = a.post(f"/maps/{map_id}/observations", json=body, headers=key)
        assert r.status_code == 200, r.text
        assert r.json()["marks"] > 5
        assert (
            b.get(f"/maps/{map_id}/live", headers=key).json()["cells"]
            == (a.get(f"/maps/{map_id}/live", headers=key).json()["cells"])
        )
        second = b.post(f"/plan/{plan_id}/step", json={}, headers=key).json()
        assert not _crosses(second["poses"], BOX, margin=RADIUS)
        other = {"X-API-Key": "kb"}
        assert b.post("/maps", json=MAP, headers=other).status_code == 201
        assert b.get(f"/maps/{map_id}/live", headers=other).json()["cells"] == []

"""``RedisStore`` against a real redis-server: maps, plans, TTL, delete, the per-plan lock and
its fenced write, and Redis out of reach."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

import numpy as np
import pytest
from pydantic import ValidationError

import planner
from service.config import Settings
from service.errors import StoreUnavailable
from service.stores import MemoryStore, RedisStore, open_store
from service.stores import redis as redis_store
from service.viewer.events import RedisBus, Subscription
from tests.service.conftest import RedisServer, free_port


@pytest.fixture
async def store(redis_server: RedisServer) -> AsyncIterator[RedisStore]:
    s = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        yield s
    finally:
        await s.close()


@pytest.mark.anyio
async def test_maps_are_kept_once_and_come_back_read_only(store: RedisStore) -> None:
    robot_map = planner.grid_map([[0, 1, -1], [0, 0, 1]], resolution=0.05, origin=[-1.5, 2, 0.3])
    assert await store.put_map("m", robot_map) is True
    assert await store.put_map("m", robot_map) is False
    got = await store.get_map("m")
    assert got is not None
    np.testing.assert_array_equal(got.occupancy, [[0, 100, -1], [0, 0, 100]])
    assert (got.resolution, got.origin) == (0.05, (-1.5, 2.0, 0.3))
    assert got.map_id == robot_map.map_id
    assert not got.occupancy.flags.writeable
    assert await store.get_map("other") is None


@pytest.mark.anyio
async def test_maps_stored_before_frames_read_back_as_plain_maps(store: RedisStore) -> None:
    grid = np.array([[0, 1, 0], [0, 0, 1]], dtype=np.uint8)
    await store._redis.set("planner:map:old", b"2x3:" + grid.tobytes())
    got = await store.get_map("old")
    assert got is not None
    assert got.plain
    assert got.map_id == planner.grid_map(grid).map_id


@pytest.mark.anyio
async def test_plans_are_written_read_and_deleted(store: RedisStore) -> None:
    await store.put_plan("p", {"state": {"iteration": 1}})
    await store.put_plan("p", {"state": {"iteration": 2}})
    assert await store.get_plan("p") == {"state": {"iteration": 2}}
    assert await store.delete_plan("p") is True
    assert await store.get_plan("p") is None
    assert await store.delete_plan("p") is False


@pytest.mark.anyio
async def test_keys_live_under_the_planner_namespace(store: RedisStore) -> None:
    await store.put_map("m", planner.grid_map(np.zeros((2, 2), dtype=np.uint8)))
    await store.put_plan("p", {})
    async with store.plan_lock("p"):
        keys = sorted(await store._redis.keys("*"))
    assert keys == [b"planner:lock:p", b"planner:map:m", b"planner:plan:p"]
    assert await store._redis.ttl("planner:map:m") == -1  # maps are kept


@pytest.mark.anyio
async def test_plans_expire_by_redis_ttl(redis_server: RedisServer) -> None:
    store = RedisStore(redis_server.url, ttl_seconds=0.3)
    try:
        await store.put_plan("p", {"n": 1})
        assert 0 < await store._redis.pttl("planner:plan:p") <= 300
        for _ in range(500):
            if await store.get_plan("p") is None:
                break
            await asyncio.sleep(0.02)
        assert await store.get_plan("p") is None
    finally:
        await store.close()


@pytest.mark.anyio
async def test_the_lock_admits_one_replica_at_a_time(redis_server: RedisServer) -> None:
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    order: list[str] = []

    async def hold(store: RedisStore, name: str) -> None:
        async with store.plan_lock("p"):
            order.append(f"{name} in")
            await asyncio.sleep(0.1)  # the other one asks for the lock meanwhile
            order.append(f"{name} out")

    try:
        await a.put_plan("p", {})
        await asyncio.gather(hold(a, "a"), hold(b, "b"), hold(a, "c"))
        assert [o.split()[1] for o in order] == ["in", "out"] * 3
        assert [o.split()[0] for o in order[::2]] == [o.split()[0] for o in order[1::2]]
        assert await a._redis.exists("planner:lock:p") == 0  # released
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_a_holder_whose_lock_expired_writes_nothing(
    redis_server: RedisServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        await a.put_plan("p", {"v": 0})
        monkeypatch.setattr(redis_store, "LOCK_TIMEOUT", 0.2)

        async def stalled(*args: object) -> None:  # a holder too stalled to renew its lock
            await asyncio.sleep(3600)

        monkeypatch.setattr(a, "_keep", stalled)
        async with a.plan_lock("p"):
            while await a._redis.exists("planner:lock:p"):  # a stalls past its lock's timeout
                await asyncio.sleep(0.02)
            async with b.plan_lock("p"):
                await b.put_plan("p", {"v": "b"})
            with pytest.raises(StoreUnavailable, match="lock expired and nothing was recorded"):
                await a.put_plan("p", {"v": "a"})
        assert await a.get_plan("p") == {"v": "b"}
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_a_step_waiting_too_long_for_the_lock_gets_503(
    redis_server: RedisServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    monkeypatch.setattr(redis_store, "LOCK_WAIT", 0.1)
    try:
        await a.put_plan("p", {})
        async with a.plan_lock("p"):
            with pytest.raises(StoreUnavailable, match="plan 'p' is busy") as caught:
                async with b.plan_lock("p"):
                    pass
        assert caught.value.status == 503
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_redis_out_of_reach_is_store_unavailable() -> None:
    port = free_port()  # nothing listens there
    store = RedisStore(f"redis://127.0.0.1:{port}/0", ttl_seconds=60)
    expected = "store unavailable; retry later"  # the address and the reason are logged only
    try:
        for call in (store.get_plan("p"), store.get_map("m"), store.delete_plan("p")):
            with pytest.raises(StoreUnavailable) as caught:
                await call
            assert caught.value.message == expected
        with pytest.raises(StoreUnavailable):
            async with store.plan_lock("p"):
                pass
        assert await store.check() == expected
    finally:
        await store.close()


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("http://redis:6379", "must be memory:// or redis://host:port/db"),
        ("redis://redis:port/0", "is not a valid Redis URL"),
    ],
)
def test_a_bad_store_url_stops_the_service_at_start(url: str, message: str) -> None:
    with pytest.raises(ValidationError, match=message):
        Settings(store_url=url)


def test_the_store_url_picks_the_store() -> None:
    assert isinstance(open_store("memory://", ttl_seconds=1), MemoryStore)
    assert isinstance(open_store("redis://127.0.0.1:6379/0", ttl_seconds=1), RedisStore)


@pytest.mark.anyio
async def test_the_lock_is_short_renewed_while_held_and_made_only_for_plans(
    redis_server: RedisServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert redis_store.LOCK_TIMEOUT <= 2.0
    monkeypatch.setattr(redis_store, "LOCK_TIMEOUT", 0.3)
    monkeypatch.setattr(redis_store, "LOCK_WAIT", 0.2)
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        async with a.plan_lock("nope") as record:
            assert record is None
            assert await a._redis.exists("planner:lock:nope") == 0
        await a.put_plan("p", {"v": 1})
        async with a.plan_lock("p") as record:
            assert record == {"v": 1}
            assert 0 < await a._redis.pttl("planner:lock:p") <= 300
            await asyncio.sleep(1.0)  # over three lifetimes: renewed meanwhile
            with pytest.raises(StoreUnavailable, match="busy"):
                async with b.plan_lock("p"):
                    pass
        assert await a._redis.exists("planner:lock:p") == 0
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_a_plan_deleted_while_a_step_holds_its_lock_stays_deleted(
    store: RedisStore,
) -> None:
    await store.put_plan("p", {"v": 0}, append=[(0, 0)])
    async with store.plan_lock("p") as record:
        assert record == {"v": 0}
        assert await store.delete_plan("p") is True  # another replica's DELETE
        assert await store.put_plan("p", {"v": 1}, append=[(0, 1)], existing=True) is False
    assert await store.get_plan("p") is None
    assert await store.get_trajectory("p") == []
    assert sorted(await store._redis.keys("*")) == []  # no lock left either


@pytest.mark.anyio
async def test_maps_expire_unless_used(redis_server: RedisServer) -> None:
    store = RedisStore(redis_server.url, ttl_seconds=60, map_ttl_seconds=0.5)
    try:
        await store.put_map("m", planner.grid_map(np.zeros((2, 2), dtype=np.uint8)))
        assert 0 < await store._redis.pttl("planner:map:m") <= 500
        await asyncio.sleep(0.3)
        assert await store.get_map("m") is not None  # used: its TTL starts again
        assert await store._redis.pttl("planner:map:m") > 300
        await store.put_plan("p", {"map_id": "m"})  # a plan written keeps its map too
        assert await store._redis.pttl("planner:map:m") > 400
        await asyncio.sleep(0.7)
        assert await store.get_map("m") is None
    finally:
        await store.close()


@pytest.mark.anyio
async def test_a_steps_write_publishes_its_event_only_when_written(
    store: RedisStore, redis_server: RedisServer
) -> None:
    """One round trip writes the step and publishes its event for the live viewer; a write
    that does not happen (the plan deleted meanwhile) publishes nothing."""
    bus = RedisBus(redis_server.url)
    subscription = await bus.subscribe("p")
    try:
        await store.put_plan("p", {"v": 0})
        async with store.plan_lock("p"):
            event = ("planner:events:p", b'{"seq":0}')
            assert await store.put_plan("p", {"v": 1}, existing=True, event=event) is True
        assert await _next_event(subscription) == {"seq": 0}
        async with store.plan_lock("p"):
            assert await store.delete_plan("p") is True
            event = ("planner:events:p", b'{"seq":1}')
            assert await store.put_plan("p", {"v": 2}, existing=True, event=event) is False
        await store._redis.publish("planner:events:p", b'{"after":true}')
        assert await _next_event(subscription) == {"after": True}  # nothing came before it
    finally:
        await subscription.close()
        await bus.close()


async def _next_event(subscription: Subscription) -> dict[str, object] | None:
    """The next event, past the subscription's confirmation (which reads as None)."""
    for _ in range(3):
        event = await subscription.next()
        if event is not None:
            return event
    return None

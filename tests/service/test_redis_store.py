"""``RedisStore`` against a real redis-server: maps, plans, TTL, delete, steps fenced by the
plan's version (one round trip, decided again when another replica wrote first), the cache of
records, and Redis out of reach."""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from typing import Any, Literal

import numpy as np
import orjson
import pytest
from pydantic import ValidationError

import planner
from service.config import Settings
from service.errors import StoreUnavailable
from service.stores import MemoryStore, PlanRecord, RedisStore, open_store, redis_link, redis_plans
from service.stores import scripts as redis_scripts
from service.stores.base import Decide, Update
from service.viewer.events import Hub, RedisBus, Subscription
from tests.service.conftest import RedisServer, free_port


class Relay:
    """A TCP relay in front of redis-server that can fail as a network does, so the store is
    tested through redis-py's own connections: ``lose()`` drops each connection open now at
    Redis's next answer (Redis did the work, the answer is lost), ``mute`` swallows answers,
    ``cut()`` closes the connections open now, ``down`` each new one as soon as it is made."""

    def __init__(self, target: int) -> None:
        self.target = target
        self.mode: Literal["relay", "mute", "down"] = "relay"
        self.lost = self.accepted = 0
        self._lose_upto = 0
        self._writers: set[asyncio.StreamWriter] = set()

    async def __aenter__(self) -> Relay:
        self._server = await asyncio.start_server(self._serve, "127.0.0.1", 0)
        self.url = f"redis://127.0.0.1:{self._server.sockets[0].getsockname()[1]}/0"
        return self

    async def __aexit__(self, *exc: object) -> None:
        self._server.close()
        for writer in list(self._writers):
            writer.close()

    def lose(self) -> None:
        self._lose_upto = self.accepted

    def cut(self) -> None:
        """Close every connection open now (nothing sent on them reaches Redis any more)."""
        for writer in list(self._writers):
            writer.close()

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.accepted += 1
        number = self.accepted
        if self.mode == "down":
            writer.close()
            return
        up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.target)
        self._writers |= {writer, up_writer}

        async def pump(src: asyncio.StreamReader, dst: asyncio.StreamWriter, answers: bool) -> None:
            try:
                while data := await src.read(65536):
                    if answers and number <= self._lose_upto:
                        self.lost += 1
                        break
                    if not (answers and self.mode == "mute"):
                        dst.write(data)
            except ConnectionError:
                pass
            finally:
                for w in (writer, up_writer):
                    w.close()
                    self._writers.discard(w)

        await asyncio.gather(pump(reader, up_writer, False), pump(up_reader, writer, True))


@pytest.fixture
async def relay(redis_server: RedisServer) -> AsyncIterator[Relay]:
    async with Relay(redis_server.port) as r:
        yield r


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
async def test_zoned_maps_come_back_with_their_zones(store: RedisStore) -> None:
    base = planner.grid_map([[0, 1, -1, 0], [0, 0, 1, 0]], resolution=0.5)
    zoned = planner.zone_map(
        base,
        keepout=[[(0.0, 0.0), (1.0, 0.0), (1.0, 0.5)]],
        speed=[{"polygon": [(1.0, 0.0), (2.0, 0.0), (2.0, 1.0)], "max_speed": 0.25}],
    )
    assert await store.put_map(zoned.map_id, zoned) is True
    got = await store.get_map(zoned.map_id)
    assert got is not None
    np.testing.assert_array_equal(got.occupancy, zoned.occupancy)
    assert got.zones == zoned.zones
    assert got.map_id == zoned.map_id


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
    await store.put_plan("p", {}, append=[(0, 0)])
    seen: list[bytes | str] = []

    async def decide(record: PlanRecord) -> Update[None]:
        seen.extend(sorted(await store._redis.keys("*"), key=str))  # mid-step: no lock key
        return Update(None, {"n": 1})

    assert await store.update_plan("p", decide) is not None
    # The tenant's set of live plans beside the plan (the tenant without keys: "").
    assert seen == [b"planner:map:m", b"planner:path:p", b"planner:plan:p", b"planner:plans-of:"]
    assert sorted(await store._redis.keys("*"), key=str) == seen
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


def _count(
    n: int = 1, *, after: asyncio.Event | None = None, log: list[int] | None = None
) -> Decide[int]:
    """A step's decision: add 1 to the record's ``n``, append the cell ``(n, 0)`` and answer
    the new ``n``; ``after`` held first (a slow step), every ``n`` decided on noted in ``log``."""

    async def decide(record: PlanRecord) -> Update[int]:
        if log is not None:
            log.append(record["n"])
        if after is not None:
            await after.wait()
        k = record["n"] + n
        return Update(k, {"n": k}, [(k, 0)], ("planner:events:p", b'{"n":%d}' % k))

    return decide


@pytest.mark.anyio
async def test_steps_on_two_replicas_never_lose_or_double_a_move(
    redis_server: RedisServer,
) -> None:
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        await a.put_plan("p", {"n": 0}, append=[(0, 0)])

        async def client(store: RedisStore, pause: float) -> list[Update[int] | None]:
            done = []
            for _ in range(15):  # one step at a time, a client's round trip between them
                done.append(await store.update_plan("p", _count()))
                await asyncio.sleep(pause)
            return done

        clients = [client(s, pause) for s in (a, b) for pause in (0.001, 0.002)]
        updates = [u for done in await asyncio.gather(*clients) for u in done]
        answers = sorted(u.answer for u in updates if u is not None)
        assert answers == list(range(1, 61))  # each step moved once, from the one before
        assert await b.get_plan("p") == {"n": 60}
        assert await a.get_trajectory("p") == [(k, 0) for k in range(61)]
        assert a.lock_count == b.lock_count == 0
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_a_step_decided_on_a_stale_record_decides_again_on_the_new_one(
    redis_server: RedisServer,
) -> None:
    """A decides on its copy while B's step is recorded: A's write is refused, and A decides
    again on B's record (read in the same round trip), so neither move is lost."""
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        await a.put_plan("p", {"n": 0}, append=[(0, 0)])
        go, seen = asyncio.Event(), list[int]()
        slow = asyncio.ensure_future(a.update_plan("p", _count(after=go, log=seen)))
        await asyncio.sleep(0.05)
        assert seen == [0]
        stepped = await b.update_plan("p", _count(10))
        assert stepped is not None
        assert stepped.answer == 10
        go.set()
        late = await slow
        assert late is not None
        assert late.answer == 11
        assert seen == [0, 10]
        assert await a.get_trajectory("p") == [(0, 0), (10, 0), (11, 0)]
        # A, B, A again: each on a copy the other's step made stale; nothing is lost.
        for store, k in ((b, 12), (a, 13), (b, 14), (a, 15)):
            update = await store.update_plan("p", _count())
            assert update is not None
            assert update.answer == k
        assert await b.get_trajectory("p") == [(0, 0), (10, 0), *((k, 0) for k in range(11, 16))]
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_a_steady_step_is_one_round_trip(
    redis_server: RedisServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One EVALSHA a step on a plan this replica last wrote; a GET before it only on a copy it
    does not have; a retried seq's replay is checked (one EVALSHA writing nothing) or, just
    read, costs nothing more."""
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    sent: list[str] = []
    for store in (a, b):
        run = store._redis.execute_command

        async def counted(*args: Any, run: Any = run, **options: Any) -> Any:
            sent.append(str(args[0]).upper())
            return await run(*args, **options)

        monkeypatch.setattr(store._redis, "execute_command", counted)
    try:
        await a.put_plan("p", {"n": 0})
        await a.update_plan("p", _count())  # the first also loads the script into Redis
        sent.clear()
        for _ in range(19):
            await a.update_plan("p", _count())
        assert sent == ["EVALSHA"] * 19
        sent.clear()
        await b.update_plan("p", _count())  # b never read it: one GET first
        assert sent == ["GET", "EVALSHA"]
        sent.clear()
        await a.update_plan("p", _count())  # a's copy is stale: refused, decided again
        assert sent == ["EVALSHA", "EVALSHA"]

        async def replay(record: PlanRecord) -> Update[int]:
            return Update(record["n"])  # nothing to write

        before = await a._redis.get("planner:plan:p")
        sent.clear()
        assert (await a.update_plan("p", replay)) == Update(22)
        assert sent == ["EVALSHA"]  # on a's copy: checked, not written
        assert await a._redis.get("planner:plan:p") == before
        await a.delete_plan("p")
        await b.put_plan("p", {"n": 5})
        sent.clear()
        assert (await a.update_plan("p", replay)) == Update(5)
        assert sent == ["GET"]  # a's copy was dropped with the delete: read, and that is all
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_steps_on_many_plans_at_once_share_round_trips(store: RedisStore) -> None:
    """Steps made while another's write is in flight go out together, in one pipeline, and
    each gets its own answer: no move lost, doubled or given to another plan."""
    plans = [f"p{i}" for i in range(12)]
    for i, plan_id in enumerate(plans):
        await store.put_plan(plan_id, {"n": 100 * i}, append=[(100 * i, 0)])
    for step in range(1, 6):
        done = await asyncio.gather(*(store.update_plan(p, _count()) for p in plans))
        assert [None if u is None else u.answer for u in done] == [
            100 * i + step for i in range(12)
        ]
    for i, plan_id in enumerate(plans):
        assert await store.get_plan(plan_id) == {"n": 100 * i + 5}
        assert await store.get_trajectory(plan_id) == [(100 * i + k, 0) for k in range(6)]
    assert 0 < store.plans.steps.pipelines < 5 * 12  # some shared a round trip


@pytest.mark.anyio
async def test_steps_whose_answers_are_lost_are_sent_once_more_and_move_once(
    relay: Relay,
) -> None:
    """The connection drops with a pipeline's answers unread: redis-py sends it once more on a
    new connection, each call finds its own write (every write's version is its own), and no
    plan moves twice or not at all."""
    store = RedisStore(relay.url, ttl_seconds=60)
    try:
        plans = [f"p{i}" for i in range(6)]
        for plan_id in plans:
            await store.put_plan(plan_id, {"n": 0}, append=[(0, 0)])
        await store.update_plan(plans[0], _count())  # connected, the script loaded
        relay.lose()
        done = await asyncio.gather(*(store.update_plan(p, _count()) for p in plans))
        assert relay.lost == 1
        assert [u.answer for u in done if u is not None] == [2, 1, 1, 1, 1, 1]
        for i, plan_id in enumerate(plans):
            n = 2 if i == 0 else 1
            assert await store.get_plan(plan_id) == {"n": n}
            assert await store.get_trajectory(plan_id) == [(k, 0) for k in range(n + 1)]
    finally:
        await store.close()


@pytest.mark.anyio
async def test_steps_fail_as_unavailable_when_redis_cannot_be_reached_then_recover(
    relay: Relay,
) -> None:
    store = RedisStore(relay.url, ttl_seconds=60)
    try:
        plans = [f"p{i}" for i in range(6)]
        for plan_id in plans:
            await store.put_plan(plan_id, {"n": 0})
        relay.mode = "down"
        relay.cut()
        results = await asyncio.gather(
            *(store.update_plan(p, _count()) for p in plans), return_exceptions=True
        )
        assert all(isinstance(r, StoreUnavailable) for r in results), results
        relay.mode = "relay"
        update = await store.update_plan("p1", _count())
        assert update is not None
        assert update.answer == 1
        assert await store.get_trajectory("p1") == [(1, 0)]
    finally:
        await store.close()


@pytest.mark.anyio
async def test_a_script_redis_lost_is_loaded_again(store: RedisStore) -> None:
    """Redis restarted (here: its scripts flushed): the step's script is loaded again and the
    step recorded once."""
    await store.put_plan("p", {"n": 0})
    await store.update_plan("p", _count())
    await store._redis.script_flush()
    update = await store.update_plan("p", _count())
    assert update is not None
    assert update.answer == 2
    assert await store.get_plan("p") == {"n": 2}


@pytest.mark.anyio
async def test_a_silent_redis_times_out_as_unavailable(
    relay: Relay, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An answer that never comes fails the step within the socket timeout (tried twice), and
    the connection is not reused."""
    monkeypatch.setattr(redis_link, "SOCKET_TIMEOUT", 0.2)
    store = RedisStore(relay.url, ttl_seconds=60)
    try:
        await store.put_plan("p", {"n": 0})
        await store.update_plan("p", _count())
        relay.mode = "mute"
        began = time.monotonic()
        with pytest.raises(StoreUnavailable):
            await store.update_plan("p", _count())
        assert time.monotonic() - began < 2.0
        relay.mode = "relay"
        assert (await store.update_plan("p", _count())) is not None
    finally:
        await store.close()


@pytest.mark.anyio
async def test_a_step_cancelled_while_waiting_cancels_none_of_the_others(
    store: RedisStore,
) -> None:
    """A caller that gives up (its request timed out) while its write waits behind one in
    flight is dropped; the others' writes go out and each gets its answer."""
    plans = [f"p{i}" for i in range(6)]
    for plan_id in plans:
        await store.put_plan(plan_id, {"n": 0}, append=[(0, 0)])
    steps = [asyncio.ensure_future(store.update_plan(p, _count())) for p in plans]
    await asyncio.sleep(0)  # each has decided and waits for its write
    steps[2].cancel()
    done = await asyncio.gather(*steps, return_exceptions=True)
    assert isinstance(done[2], asyncio.CancelledError)
    for i, plan_id in enumerate(plans):
        if i == 2:
            continue
        update = done[i]
        assert isinstance(update, Update)
        assert update.answer == 1
        assert await store.get_plan(plan_id) == {"n": 1}
    assert await store.get_plan("p2") == {"n": 0}  # dropped before it went out
    update = await store.update_plan("p2", _count())
    assert update is not None
    assert update.answer == 1


@pytest.mark.anyio
async def test_steps_waiting_when_the_store_closes_fail_as_unavailable(store: RedisStore) -> None:
    for plan_id in ("p", "q"):
        await store.put_plan(plan_id, {"n": 0})
    steps = [asyncio.ensure_future(store.update_plan(p, _count())) for p in ("p", "q")]
    await asyncio.sleep(0)  # each waits for its write, which has not gone out
    await store.close()
    done = await asyncio.wait_for(asyncio.gather(*steps, return_exceptions=True), 5)
    assert all(isinstance(r, StoreUnavailable) for r in done), done


@pytest.mark.anyio
async def test_a_write_sent_again_finds_itself_and_moves_once(relay: Relay) -> None:
    """redis-py resends a call whose answer was lost (one retry): the script finds the very
    value it would write (every write's version is its own), answers written, and the step
    does not decide and move again."""
    store = RedisStore(relay.url, ttl_seconds=60)
    decided: list[int] = []
    try:
        await store.put_plan("p", {"n": 0}, append=[(0, 0)])
        await store._redis.script_load(redis_scripts.STEP)  # no NOSCRIPT resend to count
        relay.lose()
        update = await store.update_plan("p", _count(log=decided))
        assert update is not None
        assert update.answer == 1
        assert (relay.lost, decided) == (1, [0])
        assert await store.get_plan("p") == {"n": 1}
        assert await store.get_trajectory("p") == [(0, 0), (1, 0)]
    finally:
        await store.close()


@pytest.mark.anyio
async def test_redis_py_options_in_the_url_are_honoured(redis_server: RedisServer) -> None:
    """The store is plain redis-py: RESP3, a client name and health checks come from the URL."""
    url = f"{redis_server.url}?protocol=3&client_name=planner-test&health_check_interval=30"
    store = RedisStore(url, ttl_seconds=60)
    try:
        await store.put_plan("p", {"n": 0})
        assert await store.update_plan("p", _count()) is not None
        assert await store.get_plan("p") == {"n": 1}
        info = await store._redis.client_info()
        assert (info["name"], str(info["resp"])) == ("planner-test", "3")
    finally:
        await store.close()


@pytest.mark.anyio
async def test_a_step_that_keeps_losing_the_race_gets_503(
    redis_server: RedisServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(redis_plans, "STEP_TRIES", 3)
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    tries: list[int] = []
    try:
        await a.put_plan("p", {"n": 0})

        async def loser(record: PlanRecord) -> Update[int]:
            tries.append(record["n"])
            await b.update_plan("p", _count(100))  # another replica's step, recorded first
            return Update(-1, {"n": -1})

        with pytest.raises(StoreUnavailable, match="plan 'p' is busy") as caught:
            await a.update_plan("p", loser)
        assert caught.value.status == 503
        assert tries == [0, 100, 200]
        assert await a.get_plan("p") == {"n": 300}  # nothing of a's was written
        assert a.lock_count == 0
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_a_step_refused_on_a_stale_copy_is_decided_again_on_a_fresh_read(
    redis_server: RedisServer,
) -> None:
    """A refusal (a seq out of order, say) decided on this replica's copy is checked against
    what Redis holds; one decided on a record just read is final."""
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    seen: list[int] = []

    async def only_after_b(record: PlanRecord) -> Update[int]:
        seen.append(record["n"])
        if record["n"] != 1:
            raise planner.InvalidInput("not next", field="seq")
        return Update(2, {"n": 2})

    try:
        await a.put_plan("p", {"n": 0})
        await b.update_plan("p", _count())
        update = await a.update_plan("p", only_after_b)
        assert update is not None
        assert update.answer == 2
        assert seen == [0, 1]
        seen.clear()
        await b.put_plan("q", {"n": 0})
        with pytest.raises(planner.InvalidInput, match="not next"):
            await a.update_plan("q", only_after_b)  # read fresh: refused once
        assert seen == [0]
        seen.clear()
        with pytest.raises(planner.InvalidInput, match="not next"):
            await a.update_plan("q", only_after_b)  # on a's copy, checked current: final
        assert seen == [0]
    finally:
        await a.close()
        await b.close()


@pytest.mark.anyio
async def test_records_written_before_versions_are_stepped_on(store: RedisStore) -> None:
    await store._redis.set("planner:plan:p", b'{"n":3}')
    assert await store.get_plan("p") == {"n": 3}
    update = await store.update_plan("p", _count())
    assert update is not None
    assert update.answer == 4
    stored = await store._redis.get("planner:plan:p")
    assert isinstance(stored, bytes)
    version, _, json = stored.partition(b" ")
    assert (int(version) > 0, json) == (True, b'{"n":4}')  # versioned from now on


@pytest.mark.anyio
async def test_the_cache_of_records_is_bounded(
    store: RedisStore, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(redis_plans, "CACHED_PLANS", 3)
    for i in range(10):
        await store.put_plan(f"p{i}", {"n": 0})
        await store.update_plan(f"p{i}", _count())
    assert list(store.plans.copies) == ["p7", "p8", "p9"]
    update = await store.update_plan("p0", _count())  # read again
    assert update is not None
    assert update.answer == 2


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
            await store.update_plan("p", _count())
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
async def test_a_plan_deleted_while_a_step_decides_stays_deleted(
    store: RedisStore, redis_server: RedisServer
) -> None:
    other = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        for deleting in (store, other):  # this replica's DELETE, or another's
            await store.put_plan("p", {"n": 0}, append=[(0, 0)])

            async def decide(record: PlanRecord, deleting: RedisStore = deleting) -> Update[int]:
                assert await deleting.delete_plan("p") is True
                return Update(1, {"n": 1}, [(0, 1)])

            assert await store.update_plan("p", decide) is None
            assert await store.get_plan("p") is None
            assert await store.get_trajectory("p") == []
            assert sorted(await store._redis.keys("*")) == []
            assert await store.update_plan("p", _count()) is None  # and stays unknown
        assert await store.update_plan("nope", _count()) is None
        assert store.lock_count == 0
    finally:
        await other.close()


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
    that does not happen (the plan deleted meanwhile, or a replay) publishes nothing."""
    bus = RedisBus(redis_server.url, Hub(max_bytes=1 << 20, max_streams=4))
    subscription = await bus.subscribe("p")
    try:
        await store.put_plan("p", {"n": 0})
        assert await store.update_plan("p", _count()) is not None
        assert await _next_event(subscription) == {"n": 1}

        async def replay(record: PlanRecord) -> Update[int]:
            return Update(record["n"], event=("planner:events:p", b'{"n":99}'))  # nothing to write

        assert await store.update_plan("p", replay) is not None

        async def deleted(record: PlanRecord) -> Update[int]:
            await store.delete_plan("p")
            return await _count()(record)

        assert await store.update_plan("p", deleted) is None
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
            return dict(orjson.loads(event))
    return None

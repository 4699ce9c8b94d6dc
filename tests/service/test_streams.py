"""Event streams under abuse, against real servers (uvicorn over TCP; memory and Redis stores).

A stream whose reader never reads is dropped once its queue holds ``PLANNER_STREAM_QUEUE_BYTES``
(its last event says so), on both buses; a key holds ``PLANNER_MAX_STREAMS_PER_TENANT`` streams
on a replica (503 ``TOO_MANY_STREAMS`` beyond, another key unaffected); with Redis, a replica's
streams share one pub/sub connection, so 150 streams take no pool connection each; Redis out of
reach answers 503 without its exception text.
"""

from __future__ import annotations

import asyncio
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import orjson
import pytest
import redis
import redis.asyncio

from service.errors import StoreUnavailable, TooManyStreams
from service.tenants import TENANT
from service.viewer import events
from service.viewer.events import Dropped, Hub, RedisBus
from tests.service.conftest import RedisServer, Replica, free_port, replicas

SIDE = 200
"""The map's side in cells: a circle of radius 90 m covers ~25,000 cells, a ~250 KB event."""
QUEUE = 256 * 1024
INTERNALS = ("Traceback", "127.0.0.1", "Error", "redis://", "Too many connections")


class Stream:
    """``GET /plan/{plan_id}/events`` on a raw socket, its receive buffer small: a reader that
    reads only when told to."""

    def __init__(self, replica: Replica, plan_id: str, key: str | None = None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        self.sock.settimeout(20)
        self.sock.connect(("127.0.0.1", replica.port))
        auth = f"X-API-Key: {key}\r\n" if key else ""
        request = f"GET /plan/{plan_id}/events HTTP/1.1\r\nHost: planner\r\n{auth}\r\n"
        self.sock.sendall(request.encode())
        self.received = b""
        head = self.read_until(b"\r\n\r\n")
        self.status = int(head.split(b" ", 2)[1])
        if self.status == 200:
            self.read_until(b": subscribed")

    def read_until(self, marker: bytes) -> bytes:
        while marker not in self.received:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise EOFError(f"the stream ended before {marker!r}")
            self.received += chunk
        return self.received

    def read_to_end(self) -> bytes:
        """Everything until the server ends the chunked body."""
        return self.read_until(b"\r\n0\r\n\r\n")

    def close(self) -> None:
        self.sock.close()


def _big_plan(client: httpx.Client) -> str:
    grid = [[0] * SIDE for _ in range(SIDE)]
    r = client.post("/maps", json={"grid": grid, "start": [0, 0], "goal": [SIDE - 1, 0]})
    assert r.status_code in (200, 201), r.text
    plan_id: str = r.json()["plan"]["plan_id"]
    return plan_id


def _big_steps(client: httpx.Client, plan_id: str, count: int) -> None:
    """Steps whose events are ~250 KB each (a circle far from the robot's path)."""
    circle = {"x": 150.0, "y": 100.0, "radius": 45.0}
    for seq in range(count):
        r = client.post(f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": [circle]})
        assert r.status_code == 200, r.text


@pytest.fixture(params=["memory", "redis"])
def server(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Replica]:
    env = {"PLANNER_STREAM_QUEUE_BYTES": str(QUEUE), "PLANNER_MAX_BODY_BYTES": str(8 << 20)}
    if request.param == "memory":
        with replicas("memory://", tmp_path, 1, env) as (replica,):
            yield replica
        return
    redis_server = RedisServer(tmp_path / "redis")
    redis_server.start()
    try:
        with replicas(redis_server.url, tmp_path, 1, env) as (replica,):
            yield replica
    finally:
        redis_server.stop()


def test_a_stream_that_never_reads_is_dropped_saying_why(server: Replica) -> None:
    """80 events of ~250 KB (~20 MB) behind a reader that reads nothing: its queue stops at
    256 KB, and when it reads again it finds the events already sent, then ``dropped``."""
    with httpx.Client(base_url=server.url, trust_env=False, timeout=30) as client:
        plan_id = _big_plan(client)
        idle, reader = Stream(server, plan_id), Stream(server, plan_id)
        # A reader that keeps up is not dropped: it has every step.
        keeping_up = threading.Thread(target=reader.read_until, args=(b'"seq":79',))
        keeping_up.start()
        try:
            _big_steps(client, plan_id, 80)
            keeping_up.join(timeout=60)
            assert b'"seq":79' in reader.received
            assert b"event: dropped" not in reader.received
            body = idle.read_to_end().decode()
            head, _, last = body.partition("event: dropped\ndata: ")
            assert last, body[-300:]
            error = orjson.loads(last.split("\n", 1)[0])
            assert error["code"] == "TOO_SLOW"
            assert "PLANNER_STREAM_QUEUE_BYTES" in error["detail"]
            assert head.count("data: {") < 80  # what was already on its way, no more
            # The dropped stream is gone: a new one for the same plan is served.
            again = Stream(server, plan_id)
            assert again.status == 200
            again.close()
        finally:
            idle.close()
            reader.close()


def test_a_key_holds_at_most_its_streams_and_redis_one_connection(
    redis_server: RedisServer, tmp_path: Path
) -> None:
    """150 streams of one key on one replica (over Redis' default pool of 100 connections):
    all served, over one pub/sub connection, every one getting the step; the 151st is 503
    ``TOO_MANY_STREAMS``; another key still opens its own; a stream closed frees its place."""
    env = {"PLANNER_API_KEYS": "ka,kb", "PLANNER_MAX_STREAMS_PER_TENANT": "150"}
    with (
        replicas(redis_server.url, tmp_path, 1, env) as (replica,),
        httpx.Client(
            base_url=replica.url, trust_env=False, timeout=30, headers={"X-API-Key": "ka"}
        ) as client,
    ):
        plan_ids = []
        for start in ([0, 0], [0, 1], [1, 0]):
            r = client.post("/maps", json={"rows": ["....", "....", "...."], "start": start,
                                           "goal": [2, 3]})  # fmt: skip
            assert r.status_code in (200, 201), r.text
            plan_ids.append(r.json()["plan"]["plan_id"])
        streams = [Stream(replica, plan_ids[i % 3], "ka") for i in range(150)]
        try:
            assert [s.status for s in streams] == [200] * 150
            over = Stream(replica, plan_ids[0], "ka")
            body = over.read_until(b"}").decode()
            over.close()
            assert over.status == 503, body
            assert '"code":"TOO_MANY_STREAMS"' in body
            assert "PLANNER_MAX_STREAMS_PER_TENANT" in body
            assert not any(word in body for word in INTERNALS), body
            # One pub/sub connection carries the three plans' channels.
            info = redis.Redis.from_url(redis_server.url).client_list()
            subscribers = [c for c in info if int(c["sub"]) > 0]
            assert [int(c["sub"]) for c in subscribers] == [3]
            assert len(info) < 10
            # Every stream hears its plan's step.
            assert client.post(f"/plan/{plan_ids[0]}/step", json={"seq": 0}).status_code == 200
            for stream in streams[::3]:
                stream.read_until(b'"seq":0')
            # Another key has its own streams.
            other = httpx.Client(base_url=replica.url, trust_env=False, timeout=30)
            with other:
                r = other.post(
                    "/maps", json={"rows": ["...."], "start": [0, 0], "goal": [0, 3]},
                    headers={"X-API-Key": "kb"},
                )  # fmt: skip
                theirs = Stream(replica, r.json()["plan"]["plan_id"], "kb")
                assert theirs.status == 200
                theirs.close()
            # A closed stream frees its place (once the server notices the disconnect).
            streams.pop().close()
            deadline = time.monotonic() + 20
            while True:
                again = Stream(replica, plan_ids[1], "ka")
                if again.status == 200:
                    streams.append(again)
                    break
                again.close()
                assert time.monotonic() < deadline, "the closed stream's place was not freed"
                time.sleep(0.2)
        finally:
            for stream in streams:
                stream.close()


@pytest.mark.anyio
async def test_a_hub_drops_an_inbox_over_its_bytes_and_counts_streams_per_tenant() -> None:
    hub = Hub(max_bytes=100, max_streams=2)
    slow, quick = hub.open("p"), hub.open("p")
    with pytest.raises(TooManyStreams):
        hub.open("q")
    token = TENANT.set("other")
    try:
        elsewhere = hub.open("q")  # another tenant's count
    finally:
        TENANT.reset(token)
    hub.deliver("p", b"x" * 60)
    assert await quick.next() == b"x" * 60
    hub.deliver("p", b"y" * 60)  # slow holds 120 > 100: dropped, its queue freed
    assert hub.listening("p")
    assert await quick.next() == b"y" * 60
    with pytest.raises(Dropped):
        await slow.next()
    assert slow.queued == 0
    hub.deliver("p", b"z" * 500)  # over the bound alone, into an empty queue: kept
    assert await quick.next() == b"z" * 500
    await quick.close()
    assert not hub.listening("p")
    assert hub.streams("") == 1  # the dropped stream holds its place until it is closed
    await slow.close()
    await elsewhere.close()
    assert (hub.streams(""), hub.streams("other")) == (0, 0)


@pytest.mark.anyio
async def test_redis_out_of_reach_is_503_without_its_exception_text() -> None:
    bus = RedisBus(f"redis://127.0.0.1:{free_port()}/0", Hub(max_bytes=1024, max_streams=2))
    try:
        with pytest.raises(StoreUnavailable) as caught:
            await bus.subscribe("p")
        assert caught.value.message == "store unavailable; retry later"
        assert bus.hub.streams("") == 0  # its place is freed
        await asyncio.sleep(0)
    finally:
        await bus.close()


@pytest.mark.anyio
async def test_redis_lost_ends_the_streams_and_the_next_one_reconnects(
    redis_server: RedisServer,
) -> None:
    """Redis restarted: every open stream ends (``EOFError``: browsers reconnect), and the
    next subscription opens a new pub/sub connection and hears steps again."""
    bus = RedisBus(redis_server.url, Hub(max_bytes=1 << 20, max_streams=8))
    publisher = redis.asyncio.Redis.from_url(redis_server.url)
    try:
        first, second = await bus.subscribe("p"), await bus.subscribe("q")
        await publisher.publish("planner:events:p", b'{"n":1}')
        assert await first.next() == b'{"n":1}'
        redis_server.stop()
        for subscription in (first, second):
            with pytest.raises(EOFError):
                await subscription.next()
            await subscription.close()
        with pytest.raises(StoreUnavailable):  # still down
            await bus.subscribe("p")
        # Nothing to undo for it: an UNSUBSCRIBE sent once Redis is back could come after the
        # next SUBSCRIBE of the channel (it did on a loaded machine), and that stream hear nothing.
        assert not events._PENDING
        redis_server.start()
        await publisher.aclose()
        publisher = redis.asyncio.Redis.from_url(redis_server.url)
        again = await bus.subscribe("p")
        await publisher.publish("planner:events:p", b'{"n":2}')
        assert await again.next() == b'{"n":2}'
        await again.close()
        assert bus.hub.streams("") == 0
    finally:
        await publisher.aclose()
        await bus.close()


@pytest.mark.anyio
async def test_a_plans_last_stream_closed_and_a_new_one_opened_at_once_still_hears_it(
    redis_server: RedisServer,
) -> None:
    bus = RedisBus(redis_server.url, Hub(max_bytes=1 << 20, max_streams=8))
    publisher = redis.asyncio.Redis.from_url(redis_server.url)
    try:
        old = await bus.subscribe("p")
        await old.close()  # its channel's unsubscription is on its way...
        new = await bus.subscribe("p")  # ...when a new stream of the plan comes
        await asyncio.sleep(0.1)
        await publisher.publish("planner:events:p", b'{"n":1}')
        assert await new.next() == b'{"n":1}'
        await new.close()
    finally:
        await publisher.aclose()
        await bus.close()

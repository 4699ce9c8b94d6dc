"""The Redis store: maps and plans shared by every replica of the service.

Keys, all under ``planner:``:

- ``planner:map:{map_id}``: the map as :func:`~service.stores.base.encode_map` writes it (a
  header with shape, resolution and origin, then the occupancy, one byte a cell); expires
  ``PLANNER_MAP_TTL_SECONDS`` after its last use (an upload, a read, a step of a plan on it).
- ``planner:plan:{plan_id}``: the plan's version, a space, then its record as JSON
  (``b"8841 {...}"``); expires ``PLANNER_PLAN_TTL_SECONDS`` after its last write. Each write
  (a new plan, a step) gets a new random version. A record written before versions
  (plain JSON) is read as version 0 and stepped on (its prefix is its ``{``).
- ``planner:path:{plan_id}``: the robot's trajectory, packed cells appended with ``APPEND``;
  expires with the record.

No lock lives in Redis: steps are fenced by the version (:class:`RedisStore`). With API keys,
ids are the tenant's (``{tenant}.{id}``, :func:`service.edge.tenants.scoped`).

Analyses stay in each replica's own cache: they are recomputed from the map on a miss. This is
the one module that knows ``redis``: its errors become :class:`StoreUnavailable` (or
:class:`InsufficientStorage` when Redis is at its ``maxmemory``) here, with the details logged,
not answered.
"""

from __future__ import annotations

import asyncio
import logging
import random
from collections import OrderedDict, deque
from typing import Any, cast

import hiredis
import orjson
from redis import exceptions as rx
from redis.asyncio import Redis
from redis.asyncio.connection import Connection, UnixDomainSocketConnection
from redis.asyncio.retry import Retry
from redis.backoff import NoBackoff
from redis.commands.core import AsyncScript

from planner import RobotMap, quote
from service.edge.tenants import scoped
from service.errors import InsufficientStorage, StoreUnavailable
from service.stores.base import (
    Cells,
    Decide,
    PlanLocks,
    PlanRecord,
    Store,
    T,
    Update,
    decode_map,
    encode_map,
    pack,
    unpack,
)

__all__ = ["CACHED_PLANS", "SOCKET_TIMEOUT", "STEP_TRIES", "RedisStore"]

log = logging.getLogger("service.store")

SOCKET_TIMEOUT = 2.0
"""Seconds to connect to Redis or wait for an answer before a request answers 503."""
CACHED_PLANS = 4096
"""Records each replica keeps of the plans it read or wrote last (the least recently used
are dropped): a step on one of them reads nothing before its write."""
STEP_TRIES = 16
"""Times a step decides before answering 503 when other replicas' steps on the same plan keep
writing first (each lost try means another step was recorded)."""
UNAVAILABLE = "store unavailable; retry later"
"""What a client is told when Redis cannot answer (the reason goes to the log)."""
_Cached = tuple[int, PlanRecord]
"""A plan as this replica last read or wrote it: its version and its record (read-only: what a
step decides on)."""

# A step's one round trip: KEYS the plan, its path (and its map, when maps expire); ARGV the
# version prefix the step decided on, the new value ('' for none: a replay, only checked), the
# plan's TTL, the cells to append, the map's TTL, the viewer's channel and message ('': none).
# Returns {1} (written, or checked), {0} (no such plan: nothing written), {2, value} (another
# step wrote first: the plan's value now, to decide again on). Every write has a version of its
# own (random), so a value already there exactly as this call would write it is this call's
# own write: the same call sent again (the client resends once when an answer is lost) is {1}.
_STEP = """
local now = redis.call('GET', KEYS[1])
if not now then return {0} end
if ARGV[2] ~= '' and now == ARGV[2] then return {1} end
if string.sub(now, 1, #ARGV[1]) ~= ARGV[1] then return {2, now} end
if ARGV[2] == '' then return {1} end
redis.call('SET', KEYS[1], ARGV[2], 'PX', ARGV[3])
if ARGV[4] ~= '' then redis.call('APPEND', KEYS[2], ARGV[4]) end
redis.call('PEXPIRE', KEYS[2], ARGV[3])
if KEYS[3] then redis.call('PEXPIRE', KEYS[3], ARGV[5]) end
if ARGV[6] ~= '' then redis.call('PUBLISH', ARGV[6], ARGV[7]) end
return {1}
"""

# A new plan (or a replaced one) in one round trip: the same keys and arguments, unfenced.
_PUT = """
redis.call('SET', KEYS[1], ARGV[1], 'PX', ARGV[2])
if ARGV[3] ~= '' then redis.call('APPEND', KEYS[2], ARGV[3]) end
redis.call('PEXPIRE', KEYS[2], ARGV[2])
if KEYS[3] then redis.call('PEXPIRE', KEYS[3], ARGV[4]) end
return 1
"""


class RedisStore(Store):
    """Maps and plans in Redis, for any number of replicas.

    A step is optimistic, fenced by the plan's version, and costs one round trip: the replica
    decides on the record it last read or wrote (kept in a bounded cache, else read first),
    then one script writes the new record, appends to the trajectory, refreshes the TTLs and
    publishes the viewer's event, only if the plan still exists (else 404: a plan deleted
    while a step was in flight stays deleted) and its version is still the one decided on.
    When another replica's step wrote first, the script answers the plan as it is now and the
    step decides again on it: for the same ``seq`` it replays the stored answer, for none it
    steps on from there; after ``STEP_TRIES`` lost races it answers 503. A retried ``seq`` is
    only checked (nothing written), and a step refused on this replica's copy (a ``seq`` out
    of order) is decided again on a fresh read before it is refused. No move is lost or
    doubled, nothing is ever held in Redis (a replica killed mid-step leaves nothing behind),
    and no step waits on another replica: each write has a version of its own (random), so a
    write the client sends again after its answer was lost (it resends once on a lost
    connection or a timeout) finds itself and counts as written, not as another's.

    A step's write goes over a connection of the steps' own (:class:`_Pipelined`): under load,
    the writes of steps on many plans made in one turn of the event loop go out together.

    Within a replica, steps on one plan are served one at a time, in arrival order (a
    :class:`~service.stores.base.PlanLocks` lock, in this process): so they never race each
    other, and under load on one plan each waits behind the steps queued before it, no longer.

    Connections are made on demand, with short timeouts and one immediate retry (a pooled
    connection dead since Redis restarted is replaced on first use), so the service resumes by
    itself when Redis returns.
    """

    kind = "redis"
    publishes = True

    def __init__(self, url: str, *, ttl_seconds: float, map_ttl_seconds: float = 0) -> None:
        self._redis = Redis.from_url(
            url,
            socket_timeout=SOCKET_TIMEOUT,
            socket_connect_timeout=SOCKET_TIMEOUT,
            retry=Retry(NoBackoff(), 1),
        )
        kw = self._redis.connection_pool.connection_kwargs
        # For the log only: never the password, never in an answer.
        self.address = kw.get("path") or f"{kw.get('host', 'localhost')}:{kw.get('port', 6379)}"
        self._reaching = _Reaching(self.address)
        self._ttl_ms = max(1, round(ttl_seconds * 1000))
        self._map_ttl_ms = max(0, round(map_ttl_seconds * 1000))
        self._step = _Pipelined(self._redis, self._redis.register_script(_STEP))
        self._put = self._redis.register_script(_PUT)
        self._locks = PlanLocks()
        # Scoped plan key -> (version, record: read-only), least recently used first.
        self._plans: OrderedDict[str, _Cached] = OrderedDict()

    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        key = f"planner:map:{scoped(map_id)}"
        value = encode_map(robot_map)
        with self._reaching:
            if self._map_ttl_ms:
                async with self._redis.pipeline(transaction=True) as pipe:
                    pipe.set(key, value, nx=True, px=self._map_ttl_ms)
                    pipe.pexpire(key, self._map_ttl_ms)
                    created, _ = await pipe.execute()
            else:
                created = await self._redis.set(key, value, nx=True)
        return bool(created)

    async def get_map(self, map_id: str) -> RobotMap | None:
        key = f"planner:map:{scoped(map_id)}"
        with self._reaching:
            if self._map_ttl_ms:
                value = await self._redis.getex(key, px=self._map_ttl_ms)
            else:
                value = await self._redis.get(key)
        if value is None:
            return None
        assert isinstance(value, bytes)  # no decode_responses
        return decode_map(value)

    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        key = scoped(plan_id)
        # A new plan's version starts at random: a record cached of a plan replaced under the
        # same id is never taken for the new one.
        version, json = random.getrandbits(62) + 1, orjson.dumps(record)
        with self._reaching:
            await self._put(
                keys=self._keys(key, record),
                args=[b"%d %b" % (version, json), self._ttl_ms, pack(append), self._map_ttl_ms],
            )
        self._remember(key, version, orjson.loads(json))  # a copy of its own

    async def update_plan(self, plan_id: str, decide: Decide[T]) -> Update[T] | None:
        key = scoped(plan_id)
        async with self._locks.hold(key):
            cached = self._plans.get(key)
            fresh = cached is None  # read from Redis by this step (else this replica's copy)
            if cached is None:
                cached = await self._read(key)
                if cached is None:
                    return None
            for _ in range(STEP_TRIES):
                version, record = cached
                try:
                    update = await decide(record)
                except Exception:
                    if fresh:
                        raise
                    # Refused on this replica's copy, which another replica's steps may have
                    # outdated (a seq that is next there): decided again on what Redis holds.
                    now = await self._read(key)
                    if now is None:
                        return None
                    if now[0] == version:
                        raise
                    cached, fresh = now, True
                    continue
                if update.record is None and fresh:
                    return update  # a replay of what was just read: nothing to write or check
                answer = await self._write(key, version, update)
                if answer[0] == 1:
                    return update
                if answer[0] == 0:
                    self._plans.pop(key, None)
                    return None
                cached, fresh = self._parse(key, answer[1]), True
        msg = (
            f"plan_id: plan {quote(plan_id)} is busy: other replicas' steps on it were recorded "
            f"first {STEP_TRIES} times in a row; retry later"
        )
        raise StoreUnavailable(msg, field="plan_id")

    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        value = await self._get(f"planner:plan:{scoped(plan_id)}")
        return None if value is None else dict(orjson.loads(_split(value)[1]))

    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        return unpack(await self._get(f"planner:path:{scoped(plan_id)}") or b"")

    async def delete_plan(self, plan_id: str) -> bool:
        key = scoped(plan_id)
        with self._reaching:
            gone = await self._redis.delete(f"planner:plan:{key}", f"planner:path:{key}")
        self._plans.pop(key, None)
        return bool(gone)

    @property
    def lock_count(self) -> int:
        """Plans with steps in progress or waiting on this replica (for tests)."""
        return len(self._locks)

    def _keys(self, key: str, record: PlanRecord) -> list[str]:
        keys = [f"planner:plan:{key}", f"planner:path:{key}"]
        if self._map_ttl_ms and "map_id" in record:
            keys.append(f"planner:map:{scoped(record['map_id'])}")
        return keys

    async def _write(self, key: str, version: int, update: Update[T]) -> list[bytes | int]:
        """The step's one round trip: write ``update`` if the plan is still at ``version``
        (only check it when there is nothing to write)."""
        expect = b"%d " % version if version else b"{"
        args: list[bytes | int | str]
        if update.record is None:
            keys, args = [f"planner:plan:{key}"], [expect, b""]
        else:
            json = orjson.dumps(update.record)
            written = random.getrandbits(62) + 1  # a version of its own: see _STEP
            value = b"%d %b" % (written, json)
            channel, message = update.event or ("", b"")
            keys = self._keys(key, update.record)
            args = [
                expect, value, self._ttl_ms, pack(update.append), self._map_ttl_ms, channel,
                message,
            ]  # fmt: skip
        with self._reaching:
            answer: list[bytes | int] = await self._step(keys, args)
        if answer[0] == 1 and update.record is not None:
            self._remember(key, written, update.record)
        return answer

    async def _read(self, key: str) -> _Cached | None:
        value = await self._get(f"planner:plan:{key}")
        return None if value is None else self._parse(key, value)

    def _parse(self, key: str, value: object) -> _Cached:
        assert isinstance(value, bytes)  # no decode_responses
        version, json = _split(value)
        return self._remember(key, version, orjson.loads(json))

    def _remember(self, key: str, version: int, record: PlanRecord) -> _Cached:
        entry = self._plans[key] = (version, record)
        self._plans.move_to_end(key)
        if len(self._plans) > CACHED_PLANS:
            self._plans.popitem(last=False)
        return entry

    async def counts(self) -> tuple[int, int]:
        # SCAN, not KEYS: it never blocks Redis for long. Expired plans are not listed.
        with self._reaching:
            found = [
                sum([1 async for _ in self._redis.scan_iter(match=f"planner:{kind}:*", count=1000)])
                for kind in ("map", "plan")
            ]
        return found[0], found[1]

    async def check(self) -> str | None:
        try:
            with self._reaching:
                await self._redis.ping()
        except StoreUnavailable as exc:
            return exc.message
        return None

    async def close(self) -> None:
        self._step.close()
        await self._redis.aclose()

    async def _get(self, key: str) -> bytes | None:
        with self._reaching:
            value = await self._redis.get(key)
        assert value is None or isinstance(value, bytes)  # no decode_responses
        return value


class _Reaching:
    """A ``with`` block in which the client's "Redis cannot answer" errors become
    StoreUnavailable (and "out of memory" InsufficientStorage); the reason is logged, the
    client told nothing more."""

    __slots__ = ("address",)

    def __init__(self, address: str) -> None:
        self.address = address

    def __enter__(self) -> None:
        return None

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, trace: object
    ) -> None:
        if isinstance(exc, rx.ConnectionError | rx.TimeoutError):
            log.warning("redis at %s %s", self.address, _why(exc))
            raise StoreUnavailable(UNAVAILABLE) from exc
        if isinstance(exc, rx.ResponseError):
            if str(exc).startswith("OOM"):
                log.warning("redis at %s is at its maxmemory: %s", self.address, exc)
                msg = "the store is full (Redis maxmemory); retry when plans or maps expire"
                raise InsufficientStorage(msg) from exc
            log.warning("redis at %s refused a command: %s", self.address, exc)
            raise StoreUnavailable(UNAVAILABLE) from exc


def _split(value: bytes) -> tuple[int, bytes]:
    """A stored plan's version and record (0 for a record written before versions)."""
    if value[:1] == b"{":
        return 0, value
    version, _, json = value.partition(b" ")
    return int(version), json


class _Pipelined:
    """The step script's calls, on a connection of their own, pipelined.

    A step is one call, and redis-py's client costs a call ~50 us of CPU and ~35 us of latency
    over the round trip itself (its pool's checks, its timeout contexts; measured with uvloop).
    Here the calls go over one asyncio connection in RESP, their answers parsed by hiredis
    (redis-py's own parser): a call made while none is in flight goes out at once, and the
    calls made in one turn of the event loop while some are go out in one write (a pipeline:
    under load, steps on many plans share a round trip); the answers come back in order. An
    answer not back within ``SOCKET_TIMEOUT``, or the connection lost, fails every call in
    flight on it; each is sent once more on a new connection (as redis-py's one retry does: the
    script finds its own write), then raises redis-py's ``TimeoutError`` or
    ``ConnectionError``. A script Redis does not hold (NOSCRIPT, after a restart of Redis) is
    loaded through the client, and its call sent again. A caller cancelled before its call
    went out is dropped; after, its answer is dropped. TLS (``rediss://``) goes through the
    client as any other command.
    """

    def __init__(self, redis: Redis, script: AsyncScript) -> None:
        self._redis = redis
        self._script = script
        pool = redis.connection_pool
        self._kwargs = pool.connection_kwargs
        self._direct = pool.connection_class in (Connection, UnixDomainSocketConnection)
        self._link: _Link | None = None
        self._connecting: asyncio.Lock | None = None
        self._corked: list[tuple[bytes, asyncio.Future[Any]]] = []
        self.pipelines = 0
        """Writes sent (for tests: calls that shared a round trip)."""

    async def __call__(self, keys: list[str], args: list[Any]) -> Any:
        if not self._direct:
            return await self._script(keys=keys, args=args)
        command = _command(b"EVALSHA", self._script.sha, len(keys), *keys, *args)
        try:
            answer = await self._send(command)
        except (rx.ConnectionError, rx.TimeoutError):
            answer = await self._send(command)  # once more, on a new connection
        if isinstance(answer, rx.NoScriptError):
            await self._redis.script_load(_STEP)
            answer = await self._send(command)
        if isinstance(answer, rx.ResponseError):
            raise answer
        return answer

    async def _send(self, command: bytes) -> Any:
        link = self._link
        if link is None or link.lost is not None or not link.loop.is_running():
            link = await self._connect()
        loop = link.loop  # not asyncio.get_running_loop(): a getpid system call each time
        answer: asyncio.Future[Any] = loop.create_future()
        self._corked.append((command, answer))
        if len(self._corked) == 1:
            if link.waiting:  # calls in flight: the others of this turn go with this one
                loop.call_soon(self._flush, link)
            else:  # none: out now, no turn of the loop waited for company
                self._flush(link)
        timer = loop.call_later(SOCKET_TIMEOUT, link.timed_out)
        try:
            return await answer
        finally:
            timer.cancel()

    def _flush(self, link: _Link) -> None:
        """The calls made in this turn of the event loop: out in one write (those whose caller
        is still waiting)."""
        calls = [(command, answer) for command, answer in self._corked if not answer.done()]
        self._corked = []
        if not calls:
            return
        if link.lost is not None:
            for _, answer in calls:
                answer.set_exception(link.lost)
            return
        self.pipelines += 1
        link.waiting.extend(answer for _, answer in calls)
        link.transport.write(b"".join(command for command, _ in calls))

    async def _connect(self) -> _Link:
        """The connection, made (once, whoever asks meanwhile) with redis-py's settings: its
        host and port or socket path, password and database."""
        if self._connecting is None:
            self._connecting = asyncio.Lock()
        async with self._connecting:
            link = self._link
            if link is not None and link.lost is None and link.loop.is_running():
                return link
            kw = self._kwargs
            loop = asyncio.get_running_loop()
            try:
                async with asyncio.timeout(SOCKET_TIMEOUT):
                    if "path" in kw:
                        _, link = await loop.create_unix_connection(_Link, kw["path"])
                    else:
                        host, port = kw.get("host", "localhost"), kw.get("port", 6379)
                        _, link = await loop.create_connection(_Link, host, port)
                    hello = []
                    if kw.get("password") is not None:
                        user = [kw["username"]] if kw.get("username") else []
                        hello.append(_command(b"AUTH", *user, kw["password"]))
                    if kw.get("db"):
                        hello.append(_command(b"SELECT", kw["db"]))
                    for command in hello:
                        answer: asyncio.Future[Any] = loop.create_future()
                        link.waiting.append(answer)
                        link.transport.write(command)
                        reply = await answer
                        if isinstance(reply, rx.ResponseError):
                            link.transport.close()
                            raise rx.ConnectionError(str(reply))
            except TimeoutError as exc:
                raise rx.TimeoutError("connecting timed out") from exc
            except OSError as exc:
                raise rx.ConnectionError(str(exc)) from exc
            self._link = link
            return link

    def close(self) -> None:
        if self._link is not None:
            self._link.transport.close()


class _Link(asyncio.Protocol):
    """One connection of :class:`_Pipelined`: the answers, parsed by hiredis, go to the calls
    waiting for them in the order they were sent."""

    def __init__(self) -> None:
        self.transport: asyncio.Transport
        self.loop: asyncio.AbstractEventLoop
        self.waiting: deque[asyncio.Future[Any]] = deque()
        self.lost: rx.RedisError | None = None
        self._reader = hiredis.Reader(protocolError=rx.InvalidResponse, replyError=_reply_error)

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = cast(asyncio.Transport, transport)  # uvloop's is not a subclass
        self.loop = asyncio.get_running_loop()

    def data_received(self, data: bytes) -> None:
        self._reader.feed(data)
        try:
            while (reply := self._reader.gets()) is not False:
                if not self.waiting:
                    raise rx.InvalidResponse("an answer nobody asked for")
                answer = self.waiting.popleft()
                if not answer.done():  # its caller gave up: nothing to tell
                    answer.set_result(reply)
        except rx.InvalidResponse as exc:  # not Redis speaking: drop the connection
            self.lost = rx.ConnectionError(str(exc))
            self.transport.abort()

    def connection_lost(self, exc: Exception | None) -> None:
        if self.lost is None:
            self.lost = rx.ConnectionError(f"connection lost ({type(exc).__name__})")
            self.lost.__cause__ = exc
        while self.waiting:
            answer = self.waiting.popleft()
            if not answer.done():
                answer.set_exception(self.lost)

    def timed_out(self) -> None:
        """An answer is overdue: every call in flight fails (the connection is dropped)."""
        if self.lost is None:
            self.lost = rx.TimeoutError("timed out")
        self.transport.abort()


def _reply_error(message: str) -> rx.ResponseError:
    """An error reply as redis-py raises it (NOSCRIPT as ``NoScriptError``)."""
    if message.startswith("NOSCRIPT"):
        return rx.NoScriptError(message)
    return rx.ResponseError(message)


def _command(*parts: bytes | str | int) -> bytes:
    """A command in RESP: an array of bulk strings."""
    out = [b"*%d\r\n" % len(parts)]
    for part in parts:
        if isinstance(part, str):
            data = part.encode()
        else:
            data = b"%d" % part if isinstance(part, int) else part
        out += (b"$%d\r\n" % len(data), data, b"\r\n")
    return b"".join(out)


def _why(exc: rx.RedisError) -> str:
    if isinstance(exc, rx.BusyLoadingError):
        return "is loading its data"
    if isinstance(exc, rx.TimeoutError):
        return f"did not answer within {SOCKET_TIMEOUT:g} s"
    cause = exc.__cause__ or exc.__context__
    if isinstance(cause, ConnectionRefusedError):
        return "refused the connection"
    return f"cannot be reached ({type(cause or exc).__name__})"

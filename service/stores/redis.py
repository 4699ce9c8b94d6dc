"""The Redis store: maps and plans shared by every replica, through redis-py.

Keys live under ``planner:`` (``map:``, ``plan:``, ``path:``); a step is one version-fenced
script call, so no lock is held in Redis. redis-py's errors become :class:`StoreUnavailable`
(or :class:`InsufficientStorage` at Redis's ``maxmemory``) here. Design: docs/redis-store.md.
"""

from __future__ import annotations

import asyncio
import logging
import random
from collections import OrderedDict
from typing import Any

import orjson
from redis import exceptions as rx
from redis.asyncio import Redis
from redis.asyncio.retry import Retry
from redis.backoff import NoBackoff
from redis.commands.core import AsyncScript

from planner import RobotMap, quote
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
    too_many_plans,
    unknown_map,
    unpack,
)
from service.stores.redis_fleets import FLEET_TRIES, CachedFleet, FleetSteps
from service.stores.redis_live import LIVE_MARKS, OBSERVE, LiveLayer
from service.stores.redis_values import plans_of, split
from service.stores.scripts import FLEET_DELETE, FLEET_PUT, FLEET_STEP, PUT, STEP
from service.tenants import scoped

__all__ = ["CACHED_PLANS", "FLEET_TRIES", "SOCKET_TIMEOUT", "STEP_TRIES", "RedisStore"]

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


class RedisStore(FleetSteps, LiveLayer, Store):
    """Maps and plans in Redis, for any number of replicas.

    A step decides on the record this replica last read or wrote, then one script writes it
    only if the plan's version is still the one decided on; when another replica wrote first
    it decides again on the record the script answers (``STEP_TRIES`` times at most, then 503).
    Every write has a version of its own, so a call redis-py resends after a lost answer finds
    its own write. Steps on one plan in this process take turns (:class:`PlanLocks`).
    """

    kind = "redis"
    publishes = True

    def __init__(
        self,
        url: str,
        *,
        ttl_seconds: float,
        map_ttl_seconds: float = 0,
        max_plans: int | None = None,
    ) -> None:
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
        self._max_plans = max_plans or 0
        self._step = _Collector(self._redis, self._redis.register_script(STEP))
        self._put = self._redis.register_script(PUT)
        self._fleet_step = _Collector(self._redis, self._redis.register_script(FLEET_STEP))
        self._fleet_put = self._redis.register_script(FLEET_PUT)
        self._fleet_delete = self._redis.register_script(FLEET_DELETE)
        self._observe = self._redis.register_script(OBSERVE)
        self._live_marks = self._redis.register_script(LIVE_MARKS)
        self._locks = PlanLocks()
        # Scoped plan key -> (version, record: read-only), least recently used first.
        self._plans: OrderedDict[str, _Cached] = OrderedDict()
        # Scoped fleet name -> (version, state or None: no fleet), as last read or written.
        self._fleets: OrderedDict[str, CachedFleet] = OrderedDict()
        self._progress = {}  # scoped fleet name -> its robots' progress as last read

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

    async def has_map(self, map_id: str) -> bool:
        key = f"planner:map:{scoped(map_id)}"
        with self._reaching:
            if self._map_ttl_ms:
                return bool(await self._redis.pexpire(key, self._map_ttl_ms))
            return bool(await self._redis.exists(key))

    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        key = scoped(plan_id)
        # A new plan's version starts at random: a record cached of a plan replaced under the
        # same id is never taken for the new one.
        version, json = random.getrandbits(62) + 1, orjson.dumps(record)
        value = b"%d %b" % (version, json)
        args: list[bytes | int | str] = [
            value, self._ttl_ms, pack(append), self._map_ttl_ms, self._max_plans, key,
        ]  # fmt: skip
        with self._reaching:
            written = await self._put(keys=self._keys(key, record), args=args)
        if written == 0:
            raise unknown_map(record["map_id"])
        if written < 0:
            raise too_many_plans(-written)
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
                if self._step_ended(key, answer, update.record):
                    return update if answer[0] == 1 else None
                cached, fresh = self._parse(key, answer[1]), True
        msg = (
            f"plan_id: plan {quote(plan_id)} is busy: other replicas' steps on it were recorded "
            f"first {STEP_TRIES} times in a row; retry later"
        )
        raise StoreUnavailable(msg, field="plan_id")

    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        value = await self._get(f"planner:plan:{scoped(plan_id)}")
        return None if value is None else dict(orjson.loads(split(value)[1]))

    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        return unpack(await self._get(f"planner:path:{scoped(plan_id)}") or b"")

    async def delete_plan(self, plan_id: str) -> bool:
        key = scoped(plan_id)
        value = await self._get(f"planner:plan:{key}")
        fleet = None if value is None else orjson.loads(split(value)[1]).get("fleet")
        if fleet is not None:
            return await self._leave(plan_id, key, scoped(fleet))
        with self._reaching:
            async with self._redis.pipeline(transaction=True) as pipe:
                pipe.delete(f"planner:plan:{key}", f"planner:path:{key}")
                pipe.zrem(plans_of(), key)
                gone, _ = await pipe.execute()
        self._plans.pop(key, None)
        return bool(gone)

    @property
    def lock_count(self) -> int:
        """Plans with steps in progress or waiting on this replica (for tests)."""
        return len(self._locks)

    def _keys(self, key: str, record: PlanRecord) -> list[str]:
        keys = [f"planner:plan:{key}", f"planner:path:{key}", plans_of()]
        if "map_id" in record:
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
            written = random.getrandbits(62) + 1  # a version of its own: see STEP
            value = b"%d %b" % (written, json)
            channel, message = update.event or ("", b"")
            keys = self._keys(key, update.record)
            args = [
                expect, value, self._ttl_ms, pack(update.append), self._map_ttl_ms, channel,
                message, key,
            ]  # fmt: skip
        with self._reaching:
            answer: list[bytes | int] = await self._step(keys=keys, args=args)
        if answer[0] == 1 and update.record is not None:
            self._remember(key, written, update.record)
        return answer

    async def _read(self, key: str) -> _Cached | None:
        value = await self._get(f"planner:plan:{key}")
        return None if value is None else self._parse(key, value)

    def _parse(self, key: str, value: object) -> _Cached:
        assert isinstance(value, bytes)  # no decode_responses
        version, json = split(value)
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
        await self._step.close()
        await self._fleet_step.close()
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


_Call = tuple[list[str], list[Any], "asyncio.Future[Any]"]


class _Collector:
    """The step script's calls made in one turn of the event loop while another is in flight,
    sent together in one ``pipeline(transaction=False)`` by a task of their own (a caller that
    gives up cancels nobody else's call); a lone call is sent as the script itself. A call made
    when none is in flight or waiting goes out at once from its caller: no task, no hop through
    the loop (one step at a time, as at one connection, never waits a turn for company)."""

    def __init__(self, redis: Redis, script: AsyncScript) -> None:
        self._redis, self._script = redis, script
        self._calls: list[_Call] = []
        self._sending: set[asyncio.Task[None]] = set()
        self._callers: set[asyncio.Task[Any]] = set()  # sending their own call, in flight
        self._closing = False
        self.pipelines = 0
        """Round trips made (for tests: calls that shared one)."""

    async def __call__(self, *, keys: list[str], args: list[Any]) -> Any:
        if not (self._callers or self._calls or self._sending):
            return await self._alone(keys, args)
        loop = asyncio.get_running_loop()
        answer: asyncio.Future[Any] = loop.create_future()
        self._calls.append((keys, args, answer))
        if len(self._calls) == 1:  # the first of this turn: the others join it
            task = loop.create_task(self._send())
            self._sending.add(task)
            task.add_done_callback(self._sending.discard)
        return await answer

    async def _alone(self, keys: list[str], args: list[Any]) -> Any:
        """A call sent by its caller; failed, as a collected call is, when the store closes
        meanwhile (redis-py may finish a call it was cancelled in: the cancel is then noted)."""
        task = asyncio.current_task()
        assert task is not None
        self.pipelines += 1
        self._callers.add(task)
        try:
            answer = await self._script(keys=keys, args=args)
        except asyncio.CancelledError:
            if self._closing and task.uncancel() == 0:  # the store's cancel, not another's
                raise rx.ConnectionError("the store is closing") from None
            raise
        finally:
            self._callers.discard(task)
        if self._closing and task.cancelling() and task.uncancel() == 0:
            raise rx.ConnectionError("the store is closing")
        return answer

    async def _send(self) -> None:
        calls = [call for call in self._calls if not call[2].done()]
        self._calls = []
        if not calls:
            return
        self.pipelines += 1
        answers: list[Any]
        try:
            if len(calls) == 1:
                answers = [await self._script(keys=calls[0][0], args=calls[0][1])]
            else:
                answers = await self._pipeline(calls)
        except Exception as exc:  # Redis out of reach, after redis-py's one retry
            answers = [exc] * len(calls)
        except BaseException:  # the store closing
            answers = [rx.ConnectionError("the store is closing")] * len(calls)
            raise
        finally:
            for (*_, answer), value in zip(calls, answers, strict=True):
                if answer.done():  # its caller gave up
                    continue
                if isinstance(value, BaseException):
                    answer.set_exception(value)
                else:
                    answer.set_result(value)

    async def _pipeline(self, calls: list[_Call]) -> list[Any]:
        async with self._redis.pipeline(transaction=False) as pipe:
            for keys, args, _ in calls:
                pipe.evalsha(self._script.sha, len(keys), *keys, *args)
            answers: list[Any] = await pipe.execute(raise_on_error=False)
        for i, answer in enumerate(answers):
            if isinstance(answer, rx.NoScriptError):  # Redis restarted: the script loads itself
                try:
                    answers[i] = await self._script(keys=calls[i][0], args=calls[i][1])
                except rx.RedisError as exc:
                    answers[i] = exc
        return answers

    async def close(self) -> None:
        self._closing = True
        for task in [*self._sending, *self._callers]:
            task.cancel()
        await asyncio.gather(*self._sending, return_exceptions=True)
        for *_, answer in self._calls:  # their task was cancelled before it began
            if not answer.done():
                answer.set_exception(rx.ConnectionError("the store is closing"))
        self._calls = []


def _why(exc: rx.RedisError) -> str:
    if isinstance(exc, rx.BusyLoadingError):
        return "is loading its data"
    if isinstance(exc, rx.TimeoutError):
        return f"did not answer within {SOCKET_TIMEOUT:g} s"
    cause = exc.__cause__ or exc.__context__
    if isinstance(cause, ConnectionRefusedError):
        return "refused the connection"
    return f"cannot be reached ({type(cause or exc).__name__})"

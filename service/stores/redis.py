"""The Redis store: maps and plans shared by every replica of the service.

Keys, all under ``planner:``:

- ``planner:map:{map_id}``: the map as :func:`~service.stores.base.encode_map` writes it (a
  header with shape, resolution and origin, then the occupancy, one byte a cell); expires
  ``PLANNER_MAP_TTL_SECONDS`` after its last use (an upload, a read, a step of a plan on it).
- ``planner:plan:{plan_id}``: the plan's record as JSON; expires ``PLANNER_PLAN_TTL_SECONDS``
  after its last write.
- ``planner:path:{plan_id}``: the robot's trajectory, packed cells appended with ``APPEND``;
  expires with the record.
- ``planner:lock:{plan_id}``: held by the replica stepping the plan, for ``LOCK_TIMEOUT``
  seconds renewed while it steps: a replica that dies holding it frees it within that time.

With API keys, ids are the tenant's (``{tenant}.{id}``, :func:`service.edge.tenants.scoped`).

Analyses stay in each replica's own cache: they are recomputed from the map on a miss. This is
the one module that knows ``redis``: its errors become :class:`StoreUnavailable` (or
:class:`InsufficientStorage` when Redis is at its ``maxmemory``) here, with the details logged,
not answered.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from contextvars import ContextVar

import orjson
from redis import exceptions as rx
from redis.asyncio import Redis
from redis.asyncio.retry import Retry
from redis.backoff import NoBackoff

from planner._errors import quote
from planner.robot_maps import RobotMap
from service.edge.tenants import scoped
from service.errors import InsufficientStorage, StoreUnavailable
from service.stores.base import (
    Cells,
    Event,
    PlanRecord,
    Store,
    decode_map,
    encode_map,
    pack,
    unpack,
)

__all__ = ["LOCK_TIMEOUT", "LOCK_WAIT", "SOCKET_TIMEOUT", "RedisStore"]

log = logging.getLogger("service.store")

SOCKET_TIMEOUT = 2.0
"""Seconds to connect to Redis or wait for an answer before a request answers 503."""
LOCK_TIMEOUT = 2.0
"""Seconds after which a plan's lock frees itself unless renewed: its holder renews it every
third of that while it steps, so only a dead (or stalled) holder loses it."""
LOCK_WAIT = 10.0
"""Seconds a step waits for another replica's step on the same plan before answering 503."""
UNAVAILABLE = "store unavailable; retry later"
"""What a client is told when Redis cannot answer (the reason goes to the log)."""

# The plan lock this task holds, as (plan_id, token): put_plan fences its write with it.
_held: ContextVar[tuple[str, str] | None] = ContextVar("planner_plan_lock", default=None)

# One round trip to start a step: the plan's record and its lock at once, or why not.
# Returns {1, record} (locked), {0} (no such plan: no lock made), {2, pttl} (someone holds it).
_LOCK_AND_READ = """
local record = redis.call('GET', KEYS[1])
if not record then return {0} end
if redis.call('SET', KEYS[2], ARGV[1], 'NX', 'PX', ARGV[2]) then return {1, record} end
return {2, redis.call('PTTL', KEYS[2])}
"""

# One round trip to end it: write the plan and append to its trajectory only while the lock
# holds this holder's token and (for a step) the plan still exists, refresh the map's TTL, and
# release the lock, and publish the step's event for the live viewer (when given: ARGV[7] the
# channel, ARGV[8] the message). A new plan runs the same script with no token.
# Returns 1 (written), 0 (the lock was lost: nothing written), -1 (the plan is gone).
_WRITE_AND_RELEASE = """
local mine = ARGV[2] == '' or redis.call('GET', KEYS[2]) == ARGV[2]
if ARGV[6] == '1' and redis.call('EXISTS', KEYS[1]) == 0 then
  if mine and ARGV[2] ~= '' then redis.call('DEL', KEYS[2]) end
  return -1
end
if not mine then return 0 end
redis.call('SET', KEYS[1], ARGV[1], 'PX', ARGV[3])
if ARGV[4] ~= '' then redis.call('APPEND', KEYS[3], ARGV[4]) end
redis.call('PEXPIRE', KEYS[3], ARGV[3])
if KEYS[4] ~= '' then redis.call('PEXPIRE', KEYS[4], ARGV[5]) end
if ARGV[2] ~= '' then redis.call('DEL', KEYS[2]) end
if ARGV[7] ~= '' then redis.call('PUBLISH', ARGV[7], ARGV[8]) end
return 1
"""

# Release or renew the lock only while it is still this holder's.
_RELEASE = """
if redis.call('GET', KEYS[1]) == ARGV[1] then return redis.call('DEL', KEYS[1]) end
return 0
"""
_RENEW = """
if redis.call('GET', KEYS[1]) == ARGV[1] then return redis.call('PEXPIRE', KEYS[1], ARGV[2]) end
return 0
"""


class RedisStore(Store):
    """Maps and plans in Redis, for any number of replicas.

    Steps on one plan are serialised by a per-plan lock rather than by ``WATCH``/``MULTI``: a
    step reads the plan, runs the planner (on a replica that has not seen the map yet, a whole
    analysis) and writes back. Optimistically, two replicas stepping at once would both compute,
    and the loser would redo it all; WATCH would also pin a connection for the whole
    computation. With the lock, the second waits, then reads the first's state: for the same
    ``seq`` it replays the stored answer, for none it steps on from there. No move is lost or
    doubled. A step costs two round trips: lock-and-read, then write-and-release (which also
    publishes the step's event for the live viewer: no third).

    The lock lives ``LOCK_TIMEOUT`` (2 s) and its holder renews it while it steps, so a replica
    killed mid-step frees it within 2 s. A holder that stalls past that loses it: the write back
    is fenced (the script writes only while the lock holds this holder's token), so it writes
    nothing and answers 503; its client's retry of the same ``seq`` replays what the new holder
    stored.

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
        self._ttl_ms = max(1, round(ttl_seconds * 1000))
        self._map_ttl_ms = max(0, round(map_ttl_seconds * 1000))
        self._lock_and_read = self._redis.register_script(_LOCK_AND_READ)
        self._write_and_release = self._redis.register_script(_WRITE_AND_RELEASE)
        self._release = self._redis.register_script(_RELEASE)
        self._renew = self._redis.register_script(_RENEW)

    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        key = f"planner:map:{scoped(map_id)}"
        value = encode_map(robot_map)
        async with self._reaching():
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
        async with self._reaching():
            if self._map_ttl_ms:
                value = await self._redis.getex(key, px=self._map_ttl_ms)
            else:
                value = await self._redis.get(key)
        if value is None:
            return None
        assert isinstance(value, bytes)  # no decode_responses
        return decode_map(value)

    async def put_plan(
        self,
        plan_id: str,
        record: PlanRecord,
        *,
        append: Cells = (),
        existing: bool = False,
        event: Event | None = None,
    ) -> bool:
        held = _held.get()
        token = held[1] if held is not None and held[0] == plan_id else ""
        key = scoped(plan_id)
        map_key = (
            f"planner:map:{scoped(record['map_id'])}"
            if self._map_ttl_ms and "map_id" in record
            else ""
        )
        keys = [f"planner:plan:{key}", f"planner:lock:{key}", f"planner:path:{key}", map_key]
        args: list[bytes | str | int] = [
            orjson.dumps(record), token, self._ttl_ms, pack(append), self._map_ttl_ms,
            "1" if existing else "0", *(event if event is not None else ("", b"")),
        ]  # fmt: skip
        async with self._reaching():
            written = await self._write_and_release(keys=keys, args=args)
        if token:
            _held.set((plan_id, ""))  # released by the script (or lost): nothing to release
        if written == -1:
            return False
        if not written:
            msg = (
                f"plan_id: plan {quote(plan_id)} was held over {LOCK_TIMEOUT:g} s by this step "
                "without renewal, so its lock expired and nothing was recorded; retry the step"
            )
            raise StoreUnavailable(msg, field="plan_id")
        return True

    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        value = await self._get(f"planner:plan:{scoped(plan_id)}")
        return None if value is None else dict(orjson.loads(value))

    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        return unpack(await self._get(f"planner:path:{scoped(plan_id)}") or b"")

    async def delete_plan(self, plan_id: str) -> bool:
        key = scoped(plan_id)
        async with self._reaching():
            gone = await self._redis.delete(f"planner:plan:{key}", f"planner:path:{key}")
        return bool(gone)

    @asynccontextmanager
    async def plan_lock(self, plan_id: str) -> AsyncIterator[PlanRecord | None]:
        key = scoped(plan_id)
        keys = [f"planner:plan:{key}", f"planner:lock:{key}"]
        lock_ms = max(1, round(LOCK_TIMEOUT * 1000))
        token = secrets.token_hex(16)
        deadline = time.monotonic() + LOCK_WAIT
        while True:
            async with self._reaching():
                answer = await self._lock_and_read(keys=keys, args=[token, lock_ms])
            if answer[0] == 0:
                yield None  # no such plan: no lock was made
                return
            if answer[0] == 1:
                break
            if time.monotonic() >= deadline:
                msg = (
                    f"plan_id: plan {quote(plan_id)} is busy: another step held it for over "
                    f"{LOCK_WAIT:g} s; retry later"
                )
                raise StoreUnavailable(msg, field="plan_id")
            await asyncio.sleep(min(0.01, max(0.001, int(answer[1]) / 1000)))
        held = _held.set((plan_id, token))
        # Renewed from a third of its life on: a step done sooner (nearly all) costs a timer.
        renewal: list[asyncio.Task[None]] = []
        timer = asyncio.get_running_loop().call_later(
            lock_ms / 3000,
            lambda: renewal.append(asyncio.ensure_future(self._keep(keys[1], token, lock_ms))),
        )
        try:
            yield dict(orjson.loads(answer[1]))
        finally:
            timer.cancel()
            for task in renewal:
                task.cancel()
            still = _held.get()
            _held.reset(held)
            if still is not None and still[1]:  # not released by a write: release it now
                # A Redis gone frees the lock by its timeout; the answer stands either way.
                with contextlib.suppress(rx.RedisError):
                    await self._release(keys=[keys[1]], args=[token])

    async def _keep(self, lock_key: str, token: str, lock_ms: int) -> None:
        """Renew the lock now and every third of its life while its holder steps."""
        with contextlib.suppress(rx.RedisError):
            while await self._renew(keys=[lock_key], args=[token, lock_ms]):
                await asyncio.sleep(lock_ms / 3000)

    async def counts(self) -> tuple[int, int]:
        # SCAN, not KEYS: it never blocks Redis for long. Expired plans are not listed.
        async with self._reaching():
            found = [
                sum([1 async for _ in self._redis.scan_iter(match=f"planner:{kind}:*", count=1000)])
                for kind in ("map", "plan")
            ]
        return found[0], found[1]

    async def check(self) -> str | None:
        try:
            async with self._reaching():
                await self._redis.ping()
        except StoreUnavailable as exc:
            return exc.message
        return None

    async def close(self) -> None:
        await self._redis.aclose()

    async def _get(self, key: str) -> bytes | None:
        async with self._reaching():
            value = await self._redis.get(key)
        assert value is None or isinstance(value, bytes)  # no decode_responses
        return value

    @asynccontextmanager
    async def _reaching(self) -> AsyncIterator[None]:
        """Translate the client's "Redis cannot answer" errors into StoreUnavailable (and "out of
        memory" into InsufficientStorage); the reason is logged, the client told nothing more."""
        try:
            yield
        except (rx.ConnectionError, rx.TimeoutError) as exc:
            log.warning("redis at %s %s", self.address, _why(exc))
            raise StoreUnavailable(UNAVAILABLE) from exc
        except rx.ResponseError as exc:
            if str(exc).startswith("OOM"):
                log.warning("redis at %s is at its maxmemory: %s", self.address, exc)
                msg = "the store is full (Redis maxmemory); retry when plans or maps expire"
                raise InsufficientStorage(msg) from exc
            log.warning("redis at %s refused a command: %s", self.address, exc)
            raise StoreUnavailable(UNAVAILABLE) from exc


def _why(exc: rx.RedisError) -> str:
    if isinstance(exc, rx.BusyLoadingError):
        return "is loading its data"
    if isinstance(exc, rx.TimeoutError):
        return f"did not answer within {SOCKET_TIMEOUT:g} s"
    cause = exc.__cause__ or exc.__context__
    if isinstance(cause, ConnectionRefusedError):
        return "refused the connection"
    return f"cannot be reached ({type(cause or exc).__name__})"

"""The Redis store: maps and plans shared by every replica of the service.

Keys, all under ``planner:``:

- ``planner:map:{map_id}``: the map as :func:`~service.stores.base.encode_map` writes it (a
  header with shape, resolution and origin, then the occupancy, one byte a cell); kept.
- ``planner:plan:{plan_id}``: the plan's record as JSON; expires ``PLANNER_PLAN_TTL_SECONDS``
  after its last write.
- ``planner:path:{plan_id}``: the robot's trajectory, packed cells appended with ``APPEND``;
  expires with the record.
- ``planner:lock:{plan_id}``: held by the replica stepping the plan.

Analyses stay in each replica's own cache: they are recomputed from the map on a miss. This is
the one module that knows ``redis``: its errors become :class:`StoreUnavailable` here.
"""

from __future__ import annotations

import contextlib
import secrets
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from contextvars import ContextVar

import orjson
from redis import exceptions as rx
from redis.asyncio import Redis
from redis.asyncio.lock import Lock
from redis.asyncio.retry import Retry
from redis.backoff import NoBackoff

from planner._errors import quote
from planner.robot_maps import RobotMap
from service.errors import StoreUnavailable
from service.stores.base import Cells, PlanRecord, Store, decode_map, encode_map, pack, unpack

__all__ = ["LOCK_TIMEOUT", "LOCK_WAIT", "SOCKET_TIMEOUT", "RedisStore"]

SOCKET_TIMEOUT = 2.0
"""Seconds to connect to Redis or wait for an answer before a request answers 503."""
LOCK_TIMEOUT = 30.0
"""Seconds after which a plan's lock frees itself (its holder died or stalled)."""
LOCK_WAIT = 10.0
"""Seconds a step waits for another replica's step on the same plan before answering 503."""

# The plan lock this task holds, as (plan_id, token): put_plan fences its write with it.
_held: ContextVar[tuple[str, str] | None] = ContextVar("planner_plan_lock", default=None)

# Write the plan, and append to its trajectory, only while the lock still holds this holder's
# token: one atomic script. Without a lock (a new plan) the same script runs with no token.
_FENCED_SET = """
if ARGV[2] ~= '' and redis.call('GET', KEYS[2]) ~= ARGV[2] then return 0 end
redis.call('SET', KEYS[1], ARGV[1], 'PX', ARGV[3])
if ARGV[4] ~= '' then redis.call('APPEND', KEYS[3], ARGV[4]) end
redis.call('PEXPIRE', KEYS[3], ARGV[3])
return 1
"""


class RedisStore(Store):
    """Maps and plans in Redis, for any number of replicas.

    Steps on one plan are serialised by a per-plan lock (``redis.asyncio.lock.Lock``, with a
    timeout and a blocking timeout) rather than by ``WATCH``/``MULTI``: a step reads the plan,
    runs the planner (on a replica that has not seen the map yet, a whole analysis) and writes
    back. Optimistically, two replicas stepping at once would both compute, and the loser would
    redo it all; WATCH would also pin a connection for the whole computation. With the lock, the
    second waits, then reads the first's state: for the same ``seq`` it replays the stored
    answer, for none it steps on from there. No move is lost or doubled.

    A lock that expires under a stalled holder is the known hole of Redis locks, so the write
    back is fenced: a Lua script sets the record only while the lock still holds this holder's
    token. A holder that lost its lock writes nothing and answers 503; its client's retry of the
    same ``seq`` replays what the new holder stored.

    Connections are made on demand, with short timeouts and one immediate retry (a pooled
    connection dead since Redis restarted is replaced on first use), so the service resumes by
    itself when Redis returns.
    """

    kind = "redis"

    def __init__(self, url: str, *, ttl_seconds: float) -> None:
        self._redis = Redis.from_url(
            url,
            socket_timeout=SOCKET_TIMEOUT,
            socket_connect_timeout=SOCKET_TIMEOUT,
            retry=Retry(NoBackoff(), 1),
        )
        kw = self._redis.connection_pool.connection_kwargs
        self.address = kw.get("path") or f"{kw.get('host', 'localhost')}:{kw.get('port', 6379)}"
        self._ttl_ms = max(1, round(ttl_seconds * 1000))
        self._fenced_set = self._redis.register_script(_FENCED_SET)

    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        async with self._reaching():
            created = await self._redis.set(f"planner:map:{map_id}", encode_map(robot_map), nx=True)
        return bool(created)

    async def get_map(self, map_id: str) -> RobotMap | None:
        value = await self._get(f"planner:map:{map_id}")
        return None if value is None else decode_map(value)

    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        held = _held.get()
        token = held[1] if held is not None and held[0] == plan_id else ""
        keys = [f"planner:plan:{plan_id}", f"planner:lock:{plan_id}", f"planner:path:{plan_id}"]
        args: list[bytes | str | int] = [orjson.dumps(record), token, self._ttl_ms, pack(append)]
        async with self._reaching():
            written = await self._fenced_set(keys=keys, args=args)
        if not written:
            msg = (
                f"plan_id: plan {quote(plan_id)} was held over {LOCK_TIMEOUT:g} s by this step, so "
                "its lock expired and nothing was recorded; retry the step"
            )
            raise StoreUnavailable(msg, field="plan_id")

    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        value = await self._get(f"planner:plan:{plan_id}")
        return None if value is None else dict(orjson.loads(value))

    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        return unpack(await self._get(f"planner:path:{plan_id}") or b"")

    async def delete_plan(self, plan_id: str) -> bool:
        async with self._reaching():
            gone = await self._redis.delete(f"planner:plan:{plan_id}", f"planner:path:{plan_id}")
        return bool(gone)

    @asynccontextmanager
    async def plan_lock(self, plan_id: str) -> AsyncIterator[None]:
        lock = Lock(
            self._redis,
            f"planner:lock:{plan_id}",
            timeout=LOCK_TIMEOUT,
            sleep=0.01,
            blocking_timeout=LOCK_WAIT,
            thread_local=False,
        )
        token = secrets.token_hex(16)
        async with self._reaching():
            acquired = await lock.acquire(token=token)
        if not acquired:
            msg = (
                f"plan_id: plan {quote(plan_id)} is busy: another step held it for over "
                f"{LOCK_WAIT:g} s; retry later"
            )
            raise StoreUnavailable(msg, field="plan_id")
        held = _held.set((plan_id, token))
        try:
            yield
        finally:
            _held.reset(held)
            # A lock that expired, or a Redis gone, frees itself by its timeout; the step's
            # (fenced) write stands either way, so its answer is not turned into an error.
            with contextlib.suppress(rx.RedisError):
                await lock.release()

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
        """Translate the client's "Redis cannot answer" errors into StoreUnavailable."""
        try:
            yield
        except (rx.ConnectionError, rx.TimeoutError) as exc:
            msg = f"store unavailable: redis at {self.address} {_why(exc)}; retry later"
            raise StoreUnavailable(msg) from exc


def _why(exc: rx.RedisError) -> str:
    if isinstance(exc, rx.BusyLoadingError):
        return "is loading its data"
    if isinstance(exc, rx.TimeoutError):
        return f"did not answer within {SOCKET_TIMEOUT:g} s"
    cause = exc.__cause__ or exc.__context__
    if isinstance(cause, ConnectionRefusedError):
        return "refused the connection"
    return f"cannot be reached ({cause or exc})"

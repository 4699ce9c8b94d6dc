"""The Redis store's fleets (docs/fleets.md, docs/redis-store.md): a fleet's record is one key,
``planner:fleet:{fleet}``, version-fenced as a plan's record is, and its robots' progress a hash
beside it, ``planner:fleet-progress:{fleet}`` (:mod:`service.stores.fleet_progress`). A fleet
robot's step writes its plan and its progress in one script, only if neither its plan nor the
fleet's record moved on since the step read them; it writes the record only when it changed
it. Other robots' progress, read a step late, only makes a robot wait a step longer."""

from __future__ import annotations

import random
import time
from abc import ABC, abstractmethod
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from contextlib import AbstractContextManager
from typing import Any

import orjson
from redis.asyncio import Redis

from planner import quote
from service.errors import StoreUnavailable
from service.stores.base import (
    Cells,
    FleetDecide,
    FleetJoin,
    FleetRecord,
    PlanLocks,
    PlanRecord,
    T,
    Update,
    live_fleet,
    pack,
    stamp_robot,
    too_many_plans,
    unknown_map,
)
from service.stores.fleet_progress import FleetWrite, changes
from service.stores.redis_values import plans_of, split
from service.tenants import scoped

__all__ = ["FLEET_TRIES", "CachedFleet", "FleetSteps"]

FLEET_TRIES = 64
"""Times a fleet robot's step decides before answering 503 when other replicas' steps of the
same fleet keep writing first (each lost try means another robot of the fleet was recorded)."""
CACHED_FLEETS = 4096
"""Fleet states each replica keeps of the fleets it read or wrote last."""
_Cached = tuple[int, PlanRecord]
CachedFleet = tuple[int, FleetRecord | None]
"""A fleet's record as this replica last read or wrote it: its version and value (0, None:
none)."""
_FLEET = "\0fleet "
"""The prefix of a fleet's lock key (no plan id holds a NUL)."""


def _with_map(keys: list[str]) -> list[str]:
    """A fleet's plan's keys: its map's among them (the fleet's key comes fifth)."""
    if len(keys) != 4:
        raise ValueError("a fleet's plan record names its map_id")
    return keys


class FleetSteps(ABC):
    """The fleet methods of :class:`~service.stores.redis.RedisStore` (its other half: the
    plan's record, its cache and its step script)."""

    _ttl_ms: int
    _map_ttl_ms: int
    _max_plans: int
    _locks: PlanLocks
    _plans: OrderedDict[str, _Cached]
    _fleets: OrderedDict[str, CachedFleet]
    _progress: dict[str, _Progress]
    _reaching: AbstractContextManager[None]
    _redis: Redis
    _fleet_step: Any  # the step script's collector
    _fleet_put: Callable[..., Awaitable[Any]]
    _fleet_delete: Callable[..., Awaitable[Any]]

    @abstractmethod
    async def update_plan(self, plan_id: str, decide: Any) -> Update[Any] | None: ...

    @abstractmethod
    async def _read(self, key: str) -> _Cached | None: ...

    @abstractmethod
    def _parse(self, key: str, value: object) -> _Cached: ...

    @abstractmethod
    async def _write(self, key: str, version: int, update: Update[T]) -> list[bytes | int]: ...

    @abstractmethod
    def _remember(self, key: str, version: int, record: PlanRecord) -> _Cached: ...

    @abstractmethod
    def _keys(self, key: str, record: PlanRecord) -> list[str]: ...

    @abstractmethod
    async def _get(self, key: str) -> bytes | None: ...

    async def step_plan(self, plan_id: str, decide: FleetDecide[T]) -> Update[T] | None:
        key = scoped(plan_id)
        cached = self._plans.get(key)
        if cached is None:
            cached = await self._read(key)
            if cached is None:
                return None
        fleet = cached[1].get("fleet")
        if fleet is None:
            return await self.update_plan(plan_id, lambda record: decide(record, None))
        fleet_key = scoped(fleet)
        known = self._fleets.get(fleet_key)
        if known is not None and known[1] is not None and not known[1].get("dirty"):
            # Steps that only record their robot's progress do not outdate each other: the
            # fleet's robots step at once (their scripts pipelined), fenced by the fleet's
            # record and each by its plan's.
            async with self._locks.hold(key):
                return await self._step_in_fleet(plan_id, key, fleet_key, decide)
        # The fleet changed and is solved again: one step of it at a time on this replica (the
        # fleet's lock, then the plan's), so one solves and the others find it solved.
        async with self._locks.hold(_FLEET + fleet_key), self._locks.hold(key):
            return await self._step_in_fleet(plan_id, key, fleet_key, decide)

    async def _step_in_fleet(
        self, plan_id: str, key: str, fleet_key: str, decide: FleetDecide[T]
    ) -> Update[T] | None:
        cached = self._plans.get(key)
        fresh = cached is None
        if cached is None:
            cached = await self._read(key)
            if cached is None:
                return None
        fleet = self._fleets.get(fleet_key) or await self._read_fleet(fleet_key)
        for _ in range(FLEET_TRIES):
            version, record = cached
            state = self._progress_of(fleet_key).state(fleet[1])
            try:
                update = await decide(record, live_fleet(state, time.time()))
            except Exception:
                # Refused on this replica's copies, which other replicas may have outdated? Its
                # plan first (a robot's steps on two replicas: its record is the other's).
                now = await self._read_step(key, fleet_key)
                if now is None:
                    return None
                if now[0] != version:
                    cached, fresh = now, True
                    continue
                again = await self._read_fleet(fleet_key)
                if again[0] == fleet[0]:
                    raise
                fleet, fresh = again, True
                continue
            if update.record is None:  # a replay: only checked
                if fresh:
                    return update
                answer = await self._write(key, version, update)
            else:
                write = changes(
                    state, stamp_robot(update.fleet or {}, plan_id, self._until()), plan_id
                )
                answer = await self._write_in_fleet(
                    key, version, fleet_key, fleet[0], write, update
                )
            if self._step_ended(key, answer, record):
                return update if answer[0] == 1 else None
            if answer[0] == 2:
                cached, fresh = self._parse(key, answer[1]), True
            fleet = self._fleets.get(fleet_key) or await self._read_fleet(fleet_key)
        msg = (
            f"plan_id: plan {quote(plan_id)} is busy: other replicas' steps of its fleet were "
            f"recorded first {FLEET_TRIES} times in a row; retry later"
        )
        raise StoreUnavailable(msg, field="plan_id")

    def _step_ended(self, key: str, answer: list[bytes | int], record: PlanRecord | None) -> bool:
        """Whether the step script's ``answer`` ends the step: written (1), or the plan gone (0:
        forgotten here too); the map of ``record`` gone (3) raises. Else another replica's write
        came first (2: the plan's, 4: the fleet's), to decide again on. For a plan's step
        outside any fleet too (``RedisStore.update_plan``): its script answers the same."""
        if answer[0] == 3:
            assert record is not None  # only a write checks the map
            raise unknown_map(record["map_id"])
        if answer[0] == 0:
            self._plans.pop(key, None)
        return answer[0] in (0, 1)

    def _until(self) -> float:
        """When a plan written now expires (its robot's ``until`` in its fleet)."""
        return time.time() + self._ttl_ms / 1000

    async def _write_in_fleet(
        self,
        key: str,
        version: int,
        fleet_key: str,
        fleet_version: int,
        write: FleetWrite,
        update: Update[T],
    ) -> list[bytes | int]:
        """A fleet robot's step in one round trip: the record as :meth:`_write` writes it, and
        what it changed of its fleet, if neither the plan nor the fleet's record moved on since
        ``version`` and ``fleet_version`` (and no robot ``write`` fences was told more)."""
        assert update.record is not None
        expect = b"%d " % version if version else b"{"
        written = random.getrandbits(62) + 1
        channel, message = update.event or ("", b"")
        keys = [*_with_map(self._keys(key, update.record)), *_fleet_keys(fleet_key)]
        fleet_args, fleet_written = _fleet_args(fleet_version, write)
        args: list[bytes | int | str] = [
            expect, b"%d %b" % (written, orjson.dumps(update.record)), self._ttl_ms,
            pack(update.append), self._map_ttl_ms, channel, message, key, *fleet_args,
        ]  # fmt: skip
        with self._reaching:
            answer: list[Any] = await self._fleet_step(keys=keys, args=args)
        self._learn(fleet_key, answer)
        if answer[0] == 1:
            self._remember(key, written, update.record)
            if write.record is not None:
                self._remember_fleet(fleet_key, fleet_written, write.record)
        return answer[:2]

    def _learn(self, fleet_key: str, answer: list[Any]) -> None:
        """Keep what a fleet script answered of the fleet: its record when it moved on, and its
        robots' progress."""
        if len(answer) < 4:
            return
        if answer[0] == 4 or (answer[0] == 2 and answer[2]):
            self._parse_fleet(fleet_key, answer[2])
        if answer[0] in (1, 2, 4):
            self._progress_of(fleet_key).learn(answer[3], int(answer[4]))

    def _progress_of(self, fleet_key: str) -> _Progress:
        found = self._progress.get(fleet_key)
        if found is None:
            found = self._progress[fleet_key] = _Progress()
        return found

    async def put_fleet_plan(
        self, plan_id: str, record: PlanRecord, join: FleetJoin, *, append: Cells = ()
    ) -> None:
        key, fleet_key = scoped(plan_id), scoped(record["fleet"])
        json = orjson.dumps(record)
        keys = [*_with_map(self._keys(key, record)), *_fleet_keys(fleet_key)]
        async with self._locks.hold(_FLEET + fleet_key):
            fleet = await self._read_fleet(fleet_key)
            for _ in range(FLEET_TRIES):
                state = self._progress_of(fleet_key).state(fleet[1])
                new = stamp_robot(join(live_fleet(state, time.time())), plan_id, self._until())
                fleet_args, fleet_version = _fleet_args(fleet[0], changes(state, new, plan_id))
                version = random.getrandbits(62) + 1
                args: list[bytes | int | str] = [
                    b"%d %b" % (version, json), self._ttl_ms, pack(append), self._map_ttl_ms,
                    self._max_plans, key, *fleet_args,
                ]  # fmt: skip
                with self._reaching:
                    answer = await self._fleet_put(keys=keys, args=args)
                self._learn(fleet_key, answer)
                if answer[0] == 1:
                    self._remember(key, version, orjson.loads(json))
                    self._remember_fleet(fleet_key, fleet_version, new)
                    return
                if answer[0] == 0:
                    raise unknown_map(record["map_id"])
                if answer[0] < 0:
                    raise too_many_plans(-answer[0])
                fleet = self._fleets.get(fleet_key) or await self._read_fleet(fleet_key)
        msg = f"fleet: fleet {quote(record['fleet'])} is busy; retry later"
        raise StoreUnavailable(msg, field="fleet")

    async def get_fleet(self, fleet: str) -> FleetRecord | None:
        found = await self._read_fleet(scoped(fleet))
        state = self._progress_of(scoped(fleet)).state(found[1])
        state = live_fleet(state, time.time())
        return state if state and state["robots"] else None

    async def _read_fleet(self, fleet_key: str) -> CachedFleet:
        """The fleet's record and its robots' progress, read at once (and kept)."""
        record, progress = _fleet_keys(fleet_key)
        with self._reaching:
            async with self._redis.pipeline(transaction=True) as pipe:
                pipe.get(record)
                pipe.hgetall(progress)
                pipe.time()
                value, robots, (seconds, micros) = await pipe.execute()
        self._progress_of(fleet_key).learn(robots, seconds * 1_000_000 + micros)
        return self._parse_fleet(fleet_key, value or b"")

    async def _read_step(self, key: str, fleet_key: str) -> _Cached | None:
        """A plan's record and its fleet's robots' progress, read at once: a step decided
        again on a record another replica wrote decides on its own progress as that replica
        left it (never on an older copy of it)."""
        with self._reaching:
            async with self._redis.pipeline(transaction=True) as pipe:
                pipe.get(f"planner:plan:{key}")
                pipe.hgetall(_fleet_keys(fleet_key)[1])
                pipe.time()
                value, robots, (seconds, micros) = await pipe.execute()
        self._progress_of(fleet_key).learn(robots, seconds * 1_000_000 + micros)
        return None if value is None else self._parse(key, value)

    def _parse_fleet(self, fleet_key: str, value: object) -> CachedFleet:
        assert isinstance(value, bytes)  # no decode_responses
        if not value:
            return self._remember_fleet(fleet_key, 0, None)
        version, json = split(value)
        known = self._fleets.get(fleet_key)
        if known is not None and known[0] == version and version:  # parsed already
            return self._remember_fleet(fleet_key, version, known[1])
        return self._remember_fleet(fleet_key, version, orjson.loads(json))

    def _remember_fleet(
        self, fleet_key: str, version: int, state: FleetRecord | None
    ) -> CachedFleet:
        entry = self._fleets[fleet_key] = (version, state)
        self._fleets.move_to_end(fleet_key)
        if len(self._fleets) > CACHED_FLEETS:
            gone, _ = self._fleets.popitem(last=False)
            self._progress.pop(gone, None)
        return entry

    async def _leave(self, plan_id: str, key: str, fleet_key: str) -> bool:
        """Delete a fleet's plan and its robot in the fleet at once."""
        keys = [
            f"planner:plan:{key}", f"planner:path:{key}", plans_of(), f"planner:plan:{key}",
            *_fleet_keys(fleet_key),
        ]  # fmt: skip
        async with self._locks.hold(_FLEET + fleet_key):
            fleet = await self._read_fleet(fleet_key)
            for _ in range(FLEET_TRIES):
                state = self._progress_of(fleet_key).state(fleet[1])
                robots = {} if state is None else dict(state["robots"])
                robots.pop(plan_id, None)
                live = live_fleet({**(state or {}), "robots": robots, "dirty": True}, time.time())
                write = changes(state, live or {"robots": {}}, None)
                fleet_args, _ = _fleet_args(fleet[0], write)
                if state is None or live is None or not live["robots"]:
                    fleet_args[1] = b""  # the fleet goes with its last robot
                with self._reaching:
                    answer = await self._fleet_delete(keys=keys, args=[key, *fleet_args])
                if answer[0] == 1:
                    self._plans.pop(key, None)
                    self._fleets.pop(fleet_key, None)
                    self._progress.pop(fleet_key, None)
                    return bool(answer[1])
                self._learn(fleet_key, answer)
                fleet = self._fleets.get(fleet_key) or await self._read_fleet(fleet_key)
        msg = f"plan_id: the fleet of plan {quote(plan_id)} is busy; retry later"
        raise StoreUnavailable(msg, field="plan_id")


class _Progress:
    """A fleet's robots' progress as this replica last read it (each robot's JSON, and parsed:
    only the entries that changed are parsed again), and laid over the fleet's record."""

    __slots__ = ("_at", "_merged", "_raw", "_record", "robots")

    def __init__(self) -> None:
        self._at = 0
        self._raw: dict[bytes, bytes] = {}
        self.robots: dict[str, dict[str, Any]] = {}
        self._record: FleetRecord | None = None
        self._merged: dict[str, dict[str, Any]] = {}

    def state(self, record: FleetRecord | None) -> FleetRecord | None:
        """The fleet's state: ``record`` with each robot's progress laid over its entry (the
        robots' dict a copy of its own, their entries shared: a decision copies what it
        changes)."""
        if record is None:
            return None
        if record is not self._record:
            self._record = record
            self._merged = {
                k: {**robot, **self.robots.get(k, {})} for k, robot in record["robots"].items()
            }
        return {**record, "robots": dict(self._merged)}

    def learn(self, answer: list[bytes] | dict[bytes, bytes], at: int) -> None:
        """Take the progress hash as Redis answered it (HGETALL: a flat list from a script, a
        dict from the client) at Redis's time ``at`` (microseconds), unless a later one was
        taken already: answers of calls in flight at once may come back in any order, and a
        robot's own progress must never go back to an older copy."""
        if at < self._at:
            return
        self._at = at
        pairs = (
            answer
            if isinstance(answer, dict)
            else dict(zip(answer[::2], answer[1::2], strict=True))
        )
        raw = self._raw
        for robot, value in pairs.items():
            if raw.get(robot) != value:
                raw[robot] = value
                self._lay(robot.decode(), orjson.loads(value))
        if len(raw) != len(pairs):
            for robot in [r for r in raw if r not in pairs]:
                del raw[robot]
                self._lay(robot.decode(), None)

    def _lay(self, name: str, progress: dict[str, Any] | None) -> None:
        """A robot's progress, new (None: gone), laid over its entry in the record."""
        if progress is None:
            self.robots.pop(name, None)
        else:
            self.robots[name] = progress
        own = None if self._record is None else self._record["robots"].get(name)
        if own is not None:  # replaced, never changed in place: decisions share the entries
            self._merged[name] = {**own, **(progress or {})}


def _fleet_keys(fleet_key: str) -> list[str]:
    """A fleet's two keys: its record and its robots' progress."""
    return [f"planner:fleet:{fleet_key}", f"planner:fleet-progress:{fleet_key}"]


def _fleet_args(version: int, write: FleetWrite) -> tuple[list[bytes | int | str], int]:
    """A fleet script's arguments for ``write`` decided on the record at ``version`` (see
    :mod:`service.stores.scripts`), and the version of the record it writes."""
    written = random.getrandbits(62) + 1
    record = b"" if write.record is None else b"%d %b" % (written, orjson.dumps(write.record))
    args: list[bytes | int | str] = [b"%d " % version if version else b"", record]
    args.append(len(write.progress))
    for robot, progress in write.progress.items():
        args += [robot, orjson.dumps(progress)]
    args += [len(write.gone), *write.gone, len(write.told)]
    for robot, told in write.told.items():
        args += [robot, told]
    return args, written

"""The Redis store's fleets (docs/fleets.md, docs/redis-store.md): a fleet's state is one key,
``planner:fleet:{fleet}``, version-fenced as a plan's record is; a fleet robot's step writes its
plan and its fleet in one script, only if neither moved on since the step read them."""

from __future__ import annotations

import random
import time
from abc import ABC, abstractmethod
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from contextlib import AbstractContextManager
from typing import Any

import orjson

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
"""A fleet as this replica last read or wrote it: its version and state (0, None: none)."""
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
    _reaching: AbstractContextManager[None]
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
        # One step of a fleet at a time on this replica (the fleet's lock, then the plan's):
        # only other replicas' steps can outdate the fleet state it decides on.
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
            try:
                update = await decide(record, live_fleet(fleet[1], time.time()))
            except Exception:
                # Refused on this replica's copies, which other replicas may have outdated?
                now, again = await self._read(key), await self._read_fleet(fleet_key)
                if now is None:
                    return None
                if now[0] == version and again[0] == fleet[0]:
                    raise
                cached, fleet, fresh = now, again, True
                continue
            if update.record is None:  # a replay: only checked
                if fresh:
                    return update
                answer = await self._write(key, version, update)
            else:
                answer = await self._write_in_fleet(key, version, fleet_key, fleet[0], update)
            if self._step_ended(key, answer, record):
                return update if answer[0] == 1 else None
            if answer[0] == 2:
                cached, fresh = self._parse(key, answer[1]), True
            else:
                fleet = self._parse_fleet(fleet_key, answer[1])
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

    async def _write_in_fleet(
        self, key: str, version: int, fleet_key: str, fleet_version: int, update: Update[T]
    ) -> list[bytes | int]:
        """A fleet robot's step in one round trip: the record as :meth:`_write` writes it, and
        the fleet's new state, if neither moved on since ``version`` and ``fleet_version``."""
        assert update.record is not None
        assert update.fleet is not None
        expect = b"%d " % version if version else b"{"
        written, fleet_written = random.getrandbits(62) + 1, random.getrandbits(62) + 1
        plan_id = key.rpartition(".")[2]
        state = stamp_robot(update.fleet, plan_id, time.time() + self._ttl_ms / 1000)
        channel, message = update.event or ("", b"")
        keys = [*_with_map(self._keys(key, update.record)), f"planner:fleet:{fleet_key}"]
        args: list[bytes | int | str] = [
            expect, b"%d %b" % (written, orjson.dumps(update.record)), self._ttl_ms,
            pack(update.append), self._map_ttl_ms, channel, message, key,
            b"%d " % fleet_version if fleet_version else b"",
            b"%d %b" % (fleet_written, orjson.dumps(state)),
        ]  # fmt: skip
        with self._reaching:
            answer: list[bytes | int] = await self._fleet_step(keys=keys, args=args)
        if answer[0] == 1:
            self._remember(key, written, update.record)
            self._remember_fleet(fleet_key, fleet_written, state)
        return answer

    async def put_fleet_plan(
        self, plan_id: str, record: PlanRecord, join: FleetJoin, *, append: Cells = ()
    ) -> None:
        key, fleet_key = scoped(plan_id), scoped(record["fleet"])
        json = orjson.dumps(record)
        keys = [*_with_map(self._keys(key, record)), f"planner:fleet:{fleet_key}"]
        async with self._locks.hold(_FLEET + fleet_key):
            fleet = await self._read_fleet(fleet_key)
            for _ in range(FLEET_TRIES):
                state = join(live_fleet(fleet[1], time.time()))
                state = stamp_robot(state, plan_id, time.time() + self._ttl_ms / 1000)
                version, fleet_version = random.getrandbits(62) + 1, random.getrandbits(62) + 1
                args: list[bytes | int | str] = [
                    b"%d %b" % (version, json), self._ttl_ms, pack(append), self._map_ttl_ms,
                    self._max_plans, key, b"%d " % fleet[0] if fleet[0] else b"",
                    b"%d %b" % (fleet_version, orjson.dumps(state)),
                ]  # fmt: skip
                with self._reaching:
                    answer = await self._fleet_put(keys=keys, args=args)
                if answer[0] == 1:
                    self._remember(key, version, orjson.loads(json))
                    self._remember_fleet(fleet_key, fleet_version, state)
                    return
                if answer[0] == 0:
                    raise unknown_map(record["map_id"])
                if answer[0] < 0:
                    raise too_many_plans(-answer[0])
                fleet = self._parse_fleet(fleet_key, answer[1])
        msg = f"fleet: fleet {quote(record['fleet'])} is busy; retry later"
        raise StoreUnavailable(msg, field="fleet")

    async def get_fleet(self, fleet: str) -> FleetRecord | None:
        value = await self._get(f"planner:fleet:{scoped(fleet)}")
        if value is None:
            return None
        state = live_fleet(orjson.loads(split(value)[1]), time.time())
        return state if state and state["robots"] else None

    async def _read_fleet(self, fleet_key: str) -> CachedFleet:
        value = await self._get(f"planner:fleet:{fleet_key}")
        return self._parse_fleet(fleet_key, value or b"")

    def _parse_fleet(self, fleet_key: str, value: object) -> CachedFleet:
        assert isinstance(value, bytes)  # no decode_responses
        if not value:
            return self._remember_fleet(fleet_key, 0, None)
        version, json = split(value)
        return self._remember_fleet(fleet_key, version, orjson.loads(json))

    def _remember_fleet(
        self, fleet_key: str, version: int, state: FleetRecord | None
    ) -> CachedFleet:
        entry = self._fleets[fleet_key] = (version, state)
        self._fleets.move_to_end(fleet_key)
        if len(self._fleets) > CACHED_FLEETS:
            self._fleets.popitem(last=False)
        return entry

    async def _leave(self, plan_id: str, key: str, fleet_key: str) -> bool:
        """Delete a fleet's plan and its robot in the fleet at once."""
        keys = [
            f"planner:plan:{key}", f"planner:path:{key}", plans_of(), f"planner:plan:{key}",
            f"planner:fleet:{fleet_key}",
        ]  # fmt: skip
        async with self._locks.hold(_FLEET + fleet_key):
            fleet = await self._read_fleet(fleet_key)
            for _ in range(FLEET_TRIES):
                version, state = fleet
                robots = {} if state is None else dict(state["robots"])
                robots.pop(plan_id, None)
                live = live_fleet({**(state or {}), "robots": robots, "dirty": True}, time.time())
                new = b""
                if state is not None and live is not None and live["robots"]:
                    new = b"%d %b" % (random.getrandbits(62) + 1, orjson.dumps(live))
                with self._reaching:
                    answer = await self._fleet_delete(
                        keys=keys, args=[b"%d " % version if version else b"", new, key]
                    )
                if answer[0] == 1:
                    self._plans.pop(key, None)
                    self._fleets.pop(fleet_key, None)
                    return bool(answer[1])
                fleet = self._parse_fleet(fleet_key, answer[1])
        msg = f"plan_id: the fleet of plan {quote(plan_id)} is busy; retry later"
        raise StoreUnavailable(msg, field="plan_id")

"""The Redis store's fleets (docs/fleets.md, docs/redis-store.md): a fleet's record is one key,
``planner:fleet:{fleet}``, version-fenced as a plan's record is, and its robots' progress a hash
beside it, ``planner:fleet-progress:{fleet}`` (:mod:`service.stores.fleet_progress`). A fleet
robot's step writes its plan and its progress in one script, only if neither its plan nor the
fleet's record moved on since the step read them; it writes the record only when it changed
it. Other robots' progress, read a step late, only makes a robot wait a step longer."""

from __future__ import annotations

import random
import time
from collections import OrderedDict
from typing import Any

import orjson

from planner import quote
from service.errors import StoreUnavailable
from service.stores.base import (
    Cells,
    FleetDecide,
    FleetJoin,
    FleetRecord,
    PlanRecord,
    T,
    Update,
    live_fleet,
    pack,
    stamp_robot,
    too_many_plans,
    unknown_map,
)
from service.stores.fleet_progress import FleetWrite, Progress, changes
from service.stores.redis_batch import Collector
from service.stores.redis_link import RedisLink
from service.stores.redis_live import live_key
from service.stores.redis_plans import PlanCopies
from service.stores.redis_values import plans_of, split
from service.stores.scripts import FLEET_DELETE, FLEET_PUT, FLEET_STEP
from service.tenants import scoped

__all__ = ["FLEET_TRIES", "CachedFleet", "FleetSteps"]

FLEET_TRIES = 64
"""Times a fleet robot's step decides before answering 503 when other replicas' steps of the
same fleet keep writing first (each lost try means another robot of the fleet was recorded)."""
CACHED_FLEETS = 4096
"""Fleet states each replica keeps of the fleets it read or wrote last."""
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


class FleetSteps:
    """The fleets' part of :class:`~service.stores.redis.RedisStore`: a fleet robot's step, a
    plan joining or leaving its fleet, each one script; the fleets' records and their robots'
    progress as this replica last heard them. A plan's own record, its cache and its locks are
    ``plans``'."""

    def __init__(self, link: RedisLink, plans: PlanCopies) -> None:
        self._link, self._plans = link, plans
        self.steps = Collector(link.redis, link.redis.register_script(FLEET_STEP))
        self._put = link.redis.register_script(FLEET_PUT)
        self._delete = link.redis.register_script(FLEET_DELETE)
        # Scoped fleet name -> (version, state or None: no fleet), as last read or written.
        self._fleets: OrderedDict[str, CachedFleet] = OrderedDict()
        self._progress: dict[str, Progress] = {}  # scoped fleet name -> its robots' progress

    async def step_plan(self, plan_id: str, decide: FleetDecide[T]) -> Update[T] | None:
        key = scoped(plan_id)
        cached = self._plans.copies.get(key)
        if cached is None:
            cached = await self._plans.read(key)
            if cached is None:
                return None
        fleet = cached[1].get("fleet")
        if fleet is None:
            return await self._plans.update(plan_id, lambda record: decide(record, None))
        fleet_key = scoped(fleet)
        known = self._fleets.get(fleet_key)
        if known is not None and known[1] is not None and not known[1].get("dirty"):
            # Steps that only record their robot's progress do not outdate each other: the
            # fleet's robots step at once (their scripts pipelined), fenced by the fleet's
            # record and each by its plan's.
            async with self._plans.locks.hold(key):
                return await self._step_in_fleet(plan_id, key, fleet_key, decide)
        # The fleet changed and is solved again: one step of it at a time on this replica (the
        # fleet's lock, then the plan's), so one solves and the others find it solved.
        locks = self._plans.locks
        async with locks.hold(_FLEET + fleet_key), locks.hold(key):
            return await self._step_in_fleet(plan_id, key, fleet_key, decide)

    async def _step_in_fleet(
        self, plan_id: str, key: str, fleet_key: str, decide: FleetDecide[T]
    ) -> Update[T] | None:
        plans = self._plans
        cached = plans.copies.get(key)
        fresh = cached is None
        if cached is None:
            cached = await plans.read(key)
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
                # plan first (a robot's steps on two replicas: its record is the other's), read
                # with its fleet and its map's marks, all as the other replica left them.
                keys = _fleet_keys(fleet_key)
                now, read, at = await plans.read_fresh(key, record["map_id"], keys)
                assert read is not None
                self._progress_of(fleet_key).learn(read[1], at)
                again = self._parse_fleet(fleet_key, read[0])
                if now is None:
                    return None
                if now[0] != version:
                    cached, fleet, fresh = now, again, True
                    continue
                if again[0] == fleet[0]:
                    raise
                fleet, fresh = again, True
                continue
            if update.record is None:  # a replay: only checked
                if fresh:
                    return update
                answer = await plans.write(key, version, update)
            else:
                write = changes(
                    state, stamp_robot(update.fleet or {}, plan_id, self._link.until()), plan_id
                )
                answer = await self._write_in_fleet(
                    key, version, fleet_key, fleet[0], write, update
                )
            if plans.ended(key, answer, record):
                return update if answer[0] == 1 else None
            if answer[0] == 2:
                cached, fresh = plans.parse(key, answer[1]), True
            fleet = self._fleets.get(fleet_key) or await self._read_fleet(fleet_key)
        msg = (
            f"plan_id: plan {quote(plan_id)} is busy: other replicas' steps of its fleet were "
            f"recorded first {FLEET_TRIES} times in a row; retry later"
        )
        raise StoreUnavailable(msg, field="plan_id")

    async def _write_in_fleet(
        self,
        key: str,
        version: int,
        fleet_key: str,
        fleet_version: int,
        write: FleetWrite,
        update: Update[T],
    ) -> list[bytes | int]:
        """A fleet robot's step in one round trip: the record as ``PlanCopies.write`` writes it,
        and what it changed of its fleet, if neither the plan nor the fleet's record moved on
        since ``version`` and ``fleet_version`` (and no robot ``write`` fences was told more),
        nor the map's marks since the step read them."""
        assert update.record is not None
        plans = self._plans
        keys = [*_with_map(plans.keys(key, update.record)), *_fleet_keys(fleet_key)]
        keys.append(live_key(update.record["map_id"]))
        args, written = plans.args(key, version, update)
        fleet_args, fleet_written = _fleet_args(fleet_version, write)
        with self._link.reaching:
            answer: list[Any] = await self.steps(keys=keys, args=[*args, *fleet_args])
        self._learn(fleet_key, answer)
        if answer[0] == 1:
            plans.remember(key, written, update.record)
            if write.record is not None:
                self._remember_fleet(fleet_key, fleet_written, write.record)
        return answer

    def _learn(self, fleet_key: str, answer: list[Any]) -> None:
        """Keep what a fleet script answered of the fleet: its record when it moved on, and its
        robots' progress."""
        if len(answer) < 4:
            return
        if answer[0] == 4 or (answer[0] == 2 and answer[2]):
            self._parse_fleet(fleet_key, answer[2])
        if answer[0] in (1, 2, 4, 5):
            self._progress_of(fleet_key).learn(answer[3], int(answer[4]))

    def _progress_of(self, fleet_key: str) -> Progress:
        found = self._progress.get(fleet_key)
        if found is None:
            found = self._progress[fleet_key] = Progress()
        return found

    async def put_fleet_plan(
        self, plan_id: str, record: PlanRecord, join: FleetJoin, *, append: Cells = ()
    ) -> None:
        key, fleet_key = scoped(plan_id), scoped(record["fleet"])
        json = orjson.dumps(record)
        link = self._link
        keys = [*_with_map(self._plans.keys(key, record)), *_fleet_keys(fleet_key)]
        async with self._plans.locks.hold(_FLEET + fleet_key):
            fleet = await self._read_fleet(fleet_key)
            for _ in range(FLEET_TRIES):
                state = self._progress_of(fleet_key).state(fleet[1])
                new = stamp_robot(join(live_fleet(state, time.time())), plan_id, link.until())
                fleet_args, fleet_version = _fleet_args(fleet[0], changes(state, new, plan_id))
                version = random.getrandbits(62) + 1
                args: list[bytes | int | str] = [
                    b"%d %b" % (version, json), link.ttl_ms, pack(append), link.map_ttl_ms,
                    link.max_plans, key, *fleet_args,
                ]  # fmt: skip
                with link.reaching:
                    answer = await self._put(keys=keys, args=args)
                self._learn(fleet_key, answer)
                if answer[0] == 1:
                    self._plans.remember(key, version, orjson.loads(json))
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
        with self._link.reaching:
            async with self._link.redis.pipeline(transaction=True) as pipe:
                pipe.get(record)
                pipe.hgetall(progress)
                pipe.time()
                value, robots, (seconds, micros) = await pipe.execute()
        self._progress_of(fleet_key).learn(robots, seconds * 1_000_000 + micros)
        return self._parse_fleet(fleet_key, value or b"")

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

    async def leave(self, plan_id: str, key: str, fleet_key: str) -> bool:
        """Delete a fleet's plan and its robot in the fleet at once."""
        keys = [
            f"planner:plan:{key}", f"planner:path:{key}", plans_of(), f"planner:plan:{key}",
            *_fleet_keys(fleet_key),
        ]  # fmt: skip
        async with self._plans.locks.hold(_FLEET + fleet_key):
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
                with self._link.reaching:
                    answer = await self._delete(keys=keys, args=[key, *fleet_args])
                if answer[0] == 1:
                    self._plans.copies.pop(key, None)
                    self._fleets.pop(fleet_key, None)
                    self._progress.pop(fleet_key, None)
                    return bool(answer[1])
                self._learn(fleet_key, answer)
                fleet = self._fleets.get(fleet_key) or await self._read_fleet(fleet_key)
        msg = f"plan_id: the fleet of plan {quote(plan_id)} is busy; retry later"
        raise StoreUnavailable(msg, field="plan_id")


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

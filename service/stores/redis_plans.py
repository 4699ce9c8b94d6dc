"""The Redis store's plans (docs/redis-store.md): each plan's record as this replica last read or
wrote it, and a step's write: one version-fenced script call (``STEP``), batched with the other
steps of the same turn of the event loop; the record's version, its map and its map's live
marks are checked by the script, so no lock is held in Redis."""

from __future__ import annotations

import random
from collections import OrderedDict
from typing import Any

import orjson

from planner import quote
from service.errors import StoreUnavailable
from service.stores.base import (
    Cells,
    Decide,
    PlanLocks,
    PlanRecord,
    T,
    Update,
    pack,
    too_many_plans,
    unknown_map,
)
from service.stores.redis_batch import Collector
from service.stores.redis_link import RedisLink
from service.stores.redis_live import LiveMarks, live_key
from service.stores.redis_values import plans_of, split
from service.stores.scripts import PUT, STEP
from service.tenants import scoped

__all__ = ["CACHED_PLANS", "STEP_TRIES", "Cached", "PlanCopies", "Read"]

CACHED_PLANS = 4096
"""Records each replica keeps of the plans it read or wrote last (the least recently used
are dropped): a step on one of them reads nothing before its write."""
STEP_TRIES = 16
"""Times a step decides before answering 503 when other replicas' steps on the same plan keep
writing first (each lost try means another step was recorded)."""
Cached = tuple[int, PlanRecord]
"""A plan as this replica last read or wrote it: its version and its record (read-only: what a
step decides on)."""
Read = tuple[Cached | None, tuple[bytes, dict[bytes, bytes]] | None, int]
"""A plan read afresh (None: gone), its fleet's record and robots' progress read with it (None:
not asked), and Redis's time then (microseconds)."""


class PlanCopies:
    """The plans' part of :class:`~service.stores.redis.RedisStore`: a new plan (``PUT``), a
    step (``STEP``), and the records this replica keeps. Steps on one plan in this process
    take turns (``locks``)."""

    def __init__(self, link: RedisLink, live: LiveMarks) -> None:
        self._link, self._live = link, live
        self.steps = Collector(link.redis, link.redis.register_script(STEP))
        self._put = link.redis.register_script(PUT)
        self.locks = PlanLocks()
        # Scoped plan key -> (version, record: read-only), least recently used first.
        self.copies: OrderedDict[str, Cached] = OrderedDict()

    async def put(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        key, link = scoped(plan_id), self._link
        # A new plan's version starts at random: a record cached of a plan replaced under the
        # same id is never taken for the new one.
        version, json = random.getrandbits(62) + 1, orjson.dumps(record)
        value = b"%d %b" % (version, json)
        args: list[bytes | int | str] = [
            value, link.ttl_ms, pack(append), link.map_ttl_ms, link.max_plans, key,
        ]  # fmt: skip
        with link.reaching:
            written = await self._put(keys=self.keys(key, record), args=args)
        if written == 0:
            raise unknown_map(record["map_id"])
        if written < 0:
            raise too_many_plans(-written)
        self.remember(key, version, orjson.loads(json))  # a copy of its own

    async def update(self, plan_id: str, decide: Decide[T]) -> Update[T] | None:
        """``Store.update_plan``: decide on this replica's copy, write if nobody wrote since."""
        key = scoped(plan_id)
        async with self.locks.hold(key):
            cached = self.copies.get(key)
            fresh = cached is None  # read from Redis by this step (else this replica's copy)
            if cached is None:
                cached = await self.read(key)
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
                    now, _, _ = await self.read_fresh(key, record.get("map_id"))
                    if now is None:
                        return None
                    if now[0] == version:
                        raise
                    cached, fresh = now, True
                    continue
                if update.record is None and fresh:
                    return update  # a replay of what was just read: nothing to write or check
                answer = await self.write(key, version, update)
                if self.ended(key, answer, record):
                    return update if answer[0] == 1 else None
                if answer[0] == 2:
                    cached, fresh = self.parse(key, answer[1]), True
        msg = (
            f"plan_id: plan {quote(plan_id)} is busy: other replicas' steps on it were recorded "
            f"first {STEP_TRIES} times in a row; retry later"
        )
        raise StoreUnavailable(msg, field="plan_id")

    def ended(self, key: str, answer: list[Any], record: PlanRecord) -> bool:
        """Whether a step script's ``answer`` ends the step: written (1), or the plan gone (0:
        forgotten here too); the map of ``record`` gone (3) raises. Else it decides again: on
        another replica's write (2: the plan's, 4: the fleet's) or on the map's marks, which
        moved on (5, or with 2 as its last item: kept here)."""
        if answer[0] == 3:
            raise unknown_map(record["map_id"])
        if answer[0] == 0:
            self.copies.pop(key, None)
        if answer[0] == 5:
            self._live.learn(record["map_id"], answer[1])
        elif answer[0] == 2 and len(answer) > 2 and answer[-1]:  # the marks moved on too
            self._live.learn(record["map_id"], answer[-1])
        return answer[0] in (0, 1)

    def keys(self, key: str, record: PlanRecord) -> list[str]:
        """A plan's keys: its record, its path, its tenant's plans and (named) its map."""
        keys = [f"planner:plan:{key}", f"planner:path:{key}", plans_of()]
        if "map_id" in record:
            keys.append(f"planner:map:{scoped(record['map_id'])}")
        return keys

    def args(self, key: str, version: int, update: Update[Any]) -> tuple[list[Any], int]:
        """A step script's arguments writing ``update`` decided on ``version`` (see
        :mod:`service.stores.scripts`), and the version it writes."""
        assert update.record is not None
        expect = b"%d " % version if version else b"{"
        written = random.getrandbits(62) + 1  # a version of its own: see STEP
        channel, message = update.event or ("", b"")
        value = b"%d %b" % (written, orjson.dumps(update.record))
        link = self._link
        args: list[Any] = [
            expect, value, link.ttl_ms, pack(update.append), link.map_ttl_ms, channel, message,
            key, update.marks,
        ]  # fmt: skip
        return args, written

    async def write(self, key: str, version: int, update: Update[T]) -> list[Any]:
        """The step's one round trip: write ``update`` if the plan is still at ``version`` and
        the map's marks still those it decided on (only check it when there is nothing to
        write)."""
        if update.record is None:
            expect = b"%d " % version if version else b"{"
            keys: list[str] = [f"planner:plan:{key}"]
            args: list[Any] = [expect, b""]
        else:
            keys = self.keys(key, update.record)
            if len(keys) == 4:
                keys.append(live_key(update.record["map_id"]))
            args, written = self.args(key, version, update)
        with self._link.reaching:
            answer: list[Any] = await self.steps(keys=keys, args=args)
        if answer[0] == 1 and update.record is not None:
            self.remember(key, written, update.record)
        return answer

    async def read(self, key: str) -> Cached | None:
        value = await self._link.get(f"planner:plan:{key}")
        return None if value is None else self.parse(key, value)

    async def read_fresh(
        self, key: str, map_id: str | None, fleet: list[str] | None = None
    ) -> Read:
        """A plan's record read with what a step decides on beside it, at once: its map's
        marks (kept) and, with ``fleet`` (its fleet's keys: record and progress), its fleet's
        record and robots' progress: a step decided again on a record another replica wrote
        decides on all of it as that replica left it."""
        with self._link.reaching:
            async with self._link.redis.pipeline(transaction=True) as pipe:
                pipe.get(f"planner:plan:{key}")
                pipe.time()
                if map_id is not None:
                    pipe.hgetall(live_key(map_id))
                if fleet is not None:
                    pipe.get(fleet[0])
                    pipe.hgetall(fleet[1])
                value, (seconds, micros), *rest = await pipe.execute()
        now_us = seconds * 1_000_000 + micros
        if map_id is not None:
            self._live.learn_hash(map_id, rest.pop(0), now_us)
        found = None if value is None else self.parse(key, value)
        return found, (rest[0] or b"", rest[1]) if fleet is not None else None, now_us

    def parse(self, key: str, value: object) -> Cached:
        assert isinstance(value, bytes)  # no decode_responses
        version, json = split(value)
        return self.remember(key, version, orjson.loads(json))

    def remember(self, key: str, version: int, record: PlanRecord) -> Cached:
        entry = self.copies[key] = (version, record)
        self.copies.move_to_end(key)
        if len(self.copies) > CACHED_PLANS:
            self.copies.popitem(last=False)
        return entry

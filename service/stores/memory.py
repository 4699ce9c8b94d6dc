"""The in-memory store: maps and plans in this process, for one uvicorn worker."""

from __future__ import annotations

import asyncio
import time
from collections import OrderedDict
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager

import orjson

from planner.robot_maps import RobotMap
from service.stores.base import Cells, PlanRecord, Store, pack, unpack

__all__ = ["MemoryStore"]


class MemoryStore(Store):
    """Everything in this process: for one uvicorn worker."""

    kind = "memory"

    def __init__(self, *, ttl_seconds: float, clock: Callable[[], float] = time.monotonic) -> None:
        self._ttl = ttl_seconds
        self._clock = clock
        self._maps: dict[str, RobotMap] = {}
        # Every write puts the plan last with expiry now + ttl, so the order is expiry order.
        # An entry: (expiry, the record as JSON, the trajectory log).
        self._plans: OrderedDict[str, tuple[float, bytes, bytearray]] = OrderedDict()
        self._locks: dict[str, asyncio.Lock] = {}

    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        if map_id in self._maps:
            return False
        self._maps[map_id] = robot_map  # read-only, and never shared with a writer
        return True

    async def get_map(self, map_id: str) -> RobotMap | None:
        return self._maps.get(map_id)

    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        self._expire()
        entry = self._plans.get(plan_id)
        log = entry[2] if entry else bytearray()
        log += pack(append)  # in place: appending costs what it appends
        # Serialised like a networked store would, so a record never shares state with a caller.
        self._plans[plan_id] = (self._clock() + self._ttl, orjson.dumps(record), log)
        self._plans.move_to_end(plan_id)

    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        self._expire()
        entry = self._plans.get(plan_id)
        return None if entry is None else dict(orjson.loads(entry[1]))

    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        self._expire()
        entry = self._plans.get(plan_id)
        return [] if entry is None else unpack(bytes(entry[2]))

    async def delete_plan(self, plan_id: str) -> bool:
        self._locks.pop(plan_id, None)
        return self._plans.pop(plan_id, None) is not None

    async def counts(self) -> tuple[int, int]:
        self._expire()
        return len(self._maps), len(self._plans)

    @asynccontextmanager
    async def plan_lock(self, plan_id: str) -> AsyncIterator[None]:
        lock = self._locks.setdefault(plan_id, asyncio.Lock())
        async with lock:
            yield

    def _expire(self) -> None:
        now = self._clock()
        while self._plans:
            plan_id, (expires, _, _) = next(iter(self._plans.items()))
            if expires > now:
                break
            del self._plans[plan_id]
            self._locks.pop(plan_id, None)

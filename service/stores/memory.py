"""The in-memory store: maps and plans in this process, for one uvicorn worker."""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Awaitable, Callable

import numpy as np
import numpy.typing as npt
import orjson

from planner import RobotMap
from service.stores.base import (
    Cells,
    Decide,
    FleetDecide,
    FleetJoin,
    FleetRecord,
    PlanLocks,
    PlanRecord,
    Store,
    T,
    Update,
    pack,
    too_many_plans,
    unknown_map,
    unpack,
)
from service.stores.live import LiveLayers, Marks, Seen
from service.stores.map_room import MapRoom
from service.tenants import TENANT, scoped

__all__ = ["MAP_OVERHEAD_BYTES", "MemoryStore"]

MAP_OVERHEAD_BYTES = 1024
"""What a stored map costs beside its cells (its arrays' headers, frame, id and entry: ~760
bytes measured with tracemalloc), counted against ``PLANNER_MAP_STORE_BYTES``: so the bound
holds for many tiny maps too (a key's share holds at most share / 1 KiB maps)."""

_Entry = tuple[float, bytes, bytearray, str | None, PlanRecord]


class MemoryStore(Store):
    """Everything in this process: for one uvicorn worker.

    Maps take at most ``max_map_bytes``: a new map evicts the least recently used maps that no
    live plan uses, and is refused (507) when those do not free enough (:class:`MapRoom`: each
    map kept with its size, the bookkeeping incremental). Each tenant holds at most
    ``max_plans`` live plans (429 beyond).
    """

    kind = "memory"

    def __init__(
        self,
        *,
        ttl_seconds: float,
        max_map_bytes: int | None = None,
        shares: int = 1,
        max_plans: int | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._ttl = ttl_seconds
        self._max_plans = max_plans
        self._plans_of: dict[str, int] = {}  # live plans per tenant
        self._clock = clock
        self.max_map_bytes = max_map_bytes
        # Each tenant's maps take at most an equal share: one key cannot evict another's maps.
        self._maps = MapRoom(max_map_bytes, shares=shares)
        # Every write puts the plan last with expiry now + ttl, so the order is expiry order.
        # An entry: (expiry, the record as JSON, the trajectory log, its map's key, the record
        # itself: read-only, what a step decides on).
        self._plans: OrderedDict[str, _Entry] = OrderedDict()
        self._locks = PlanLocks()
        self._fleets: dict[str, FleetRecord] = {}  # by scoped fleet name: read-only records
        self._live = LiveLayers(clock)

    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        key = scoped(map_id)
        if key in self._maps:
            self._maps.touch(key)
            return False
        self._expire()  # expired plans hold no map
        # Read-only, and never shared with a writer.
        self._maps.put(key, robot_map, size=_size(robot_map), tenant=TENANT.get())
        return True

    @property
    def map_bytes(self) -> int:
        """The bytes the stored maps take."""
        return self._maps.bytes

    async def get_map(self, map_id: str) -> RobotMap | None:
        return self._maps.get(scoped(map_id))

    async def has_map(self, map_id: str) -> bool:
        return await self.get_map(map_id) is not None

    async def counts(self) -> tuple[int, int]:
        self._expire()
        return len(self._maps), len(self._plans)

    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        self._expire()
        key = scoped(plan_id)
        self._check_room(key, record)
        self._write(key, orjson.loads(orjson.dumps(record)), append)  # its own copy

    def _check_room(self, key: str, record: PlanRecord) -> None:
        """A new plan's map must be stored, and its tenant under its number of plans."""
        if "map_id" in record and scoped(record["map_id"]) not in self._maps:
            raise unknown_map(record["map_id"])
        held = self._plans_of.get(TENANT.get(), 0)
        if self._max_plans is not None and key not in self._plans and held >= self._max_plans:
            raise too_many_plans(held)

    async def update_plan(self, plan_id: str, decide: Decide[T]) -> Update[T] | None:
        return await self._update(scoped(plan_id), lambda record: decide(record))

    async def step_plan(self, plan_id: str, decide: FleetDecide[T]) -> Update[T] | None:
        key = scoped(plan_id)
        self._expire()
        entry = self._plans.get(key)
        if entry is None:
            return None
        fleet = entry[4].get("fleet")
        if fleet is None:
            return await self._update(key, lambda record: decide(record, None))
        fleet_key = scoped(fleet)
        # One step of a fleet at a time in this process (a fleet lock, then the plan's): each
        # decides on the fleet state the previous one wrote.
        async with self._locks.hold(_FLEET + fleet_key):
            return await self._update(
                key, lambda record: decide(record, self._fleets.get(fleet_key)), fleet_key
            )

    async def _update(
        self,
        key: str,
        decide: Callable[[PlanRecord], Awaitable[Update[T]]],
        fleet_key: str | None = None,
    ) -> Update[T] | None:
        self._expire()
        if key not in self._plans:
            return None  # no lock is made for a plan that does not exist
        async with self._locks.hold(key):
            # Read under the lock: the previous holder's write, or its delete, is seen.
            entry = self._plans.get(key)
            if entry is None:
                return None
            update = await decide(entry[4])
            if update.record is not None:
                if key not in self._plans or self._plans[key][0] <= self._clock():
                    return None  # deleted (or expired) while the step decided: it stays so
                self._write(key, update.record, update.append)
                if fleet_key is not None and update.fleet is not None:
                    self._step_fleet(fleet_key, key, update.fleet)
            return update

    def _step_fleet(self, fleet_key: str, key: str, fleet: FleetRecord) -> None:
        """Write the fleet as the step decided it (under the fleet's lock, on the state the
        previous step wrote); a robot deleted or expired while the step decided stays gone."""
        plan_id = key.rpartition(".")[2]
        now = self._fleets.get(fleet_key)
        if plan_id not in fleet["robots"] or now is None:
            return
        gone = fleet["robots"].keys() - now["robots"].keys() - {plan_id}
        if gone:
            robots = {k: v for k, v in fleet["robots"].items() if k not in gone}
            fleet = {**fleet, "robots": robots, "dirty": True}
        self._fleets[fleet_key] = fleet

    async def put_fleet_plan(
        self, plan_id: str, record: PlanRecord, join: FleetJoin, *, append: Cells = ()
    ) -> None:
        self._expire()
        fleet_key = scoped(record["fleet"])
        async with self._locks.hold(_FLEET + fleet_key):
            fleet = join(self._fleets.get(fleet_key))
            self._check_room(scoped(plan_id), record)
            self._write(scoped(plan_id), orjson.loads(orjson.dumps(record)), append)
            self._fleets[fleet_key] = orjson.loads(orjson.dumps(fleet))

    async def get_fleet(self, fleet: str) -> FleetRecord | None:
        self._expire()
        found = self._fleets.get(scoped(fleet))
        return None if found is None else orjson.loads(orjson.dumps(found))

    def _write(self, key: str, record: PlanRecord, append: Cells) -> None:
        entry = self._plans.get(key)
        if entry is None:
            map_key = scoped(record["map_id"]) if "map_id" in record else None
            if map_key is not None:
                self._maps.use(map_key)
            tenant = _owner(key)
            self._plans_of[tenant] = self._plans_of.get(tenant, 0) + 1
            log = bytearray()
        else:
            log, map_key = entry[2], entry[3]
        log += pack(append)  # in place: appending costs what it appends
        # Serialised like a networked store would (a record that is not JSON fails here); a
        # record is handed out as a copy (get_plan) or read-only (update_plan).
        self._plans[key] = (self._clock() + self._ttl, orjson.dumps(record), log, map_key, record)
        self._plans.move_to_end(key)
        if map_key is not None:
            self._maps.touch(map_key)

    async def observe(self, map_id: str, seen: Seen) -> int:
        return self._live.observe(scoped(map_id), seen)

    async def live_marks(self, map_id: str) -> npt.NDArray[np.int64]:
        return self._live.marks(scoped(map_id))

    async def known_marks(self, map_id: str) -> Marks:
        return Marks(self._live.marks(scoped(map_id)))  # exact: nothing to check at the write

    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        self._expire()
        entry = self._plans.get(scoped(plan_id))
        return None if entry is None else dict(orjson.loads(entry[1]))

    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        self._expire()
        entry = self._plans.get(scoped(plan_id))
        return [] if entry is None else unpack(bytes(entry[2]))

    async def delete_plan(self, plan_id: str) -> bool:
        self._expire()
        return self._forget(scoped(plan_id))

    @property
    def lock_count(self) -> int:
        """Locks held or waited for now (for tests: none is left behind)."""
        return len(self._locks)

    def _forget(self, key: str) -> bool:
        entry = self._plans.pop(key, None)
        if entry is None:
            return False
        fleet = entry[4].get("fleet")
        if fleet is not None:
            self._leave(key, fleet)
        tenant = _owner(key)
        left = self._plans_of[tenant] - 1
        if left:
            self._plans_of[tenant] = left
        else:
            del self._plans_of[tenant]
        map_key = entry[3]
        if map_key is not None:
            self._maps.leave(map_key)
        return True

    def _expire(self) -> None:
        now = self._clock()
        while self._plans:
            key, entry = next(iter(self._plans.items()))
            if entry[0] > now:
                break
            self._forget(key)

    def _leave(self, key: str, fleet: str) -> None:
        """The plan's robot leaves its fleet (the fleet goes with its last robot; the others
        are solved again at their next step)."""
        tenant, _, plan_id = key.rpartition(".")
        fleet_key = f"{tenant}.{fleet}" if tenant else fleet
        now = self._fleets.get(fleet_key)
        if now is None:
            return
        robots = {k: v for k, v in now["robots"].items() if k != plan_id}
        if robots:
            self._fleets[fleet_key] = {**now, "robots": robots, "dirty": True}
        else:
            del self._fleets[fleet_key]


_FLEET = "\0fleet "
"""The prefix of a fleet's lock key (no plan id holds a NUL)."""


def _owner(key: str) -> str:
    """The tenant of a stored map or plan key (``""`` without keys): ids hold no dot."""
    return key.split(".", 1)[0] if "." in key else ""


def _size(robot_map: RobotMap) -> int:
    """The bytes a stored map holds: one per cell, a zoned map's zones (counted by their points,
    once: the size is kept with the map), and its bookkeeping."""
    zones = 0 if robot_map.zones is None else robot_map.zones.nbytes
    return int(robot_map.occupancy.nbytes) + zones + MAP_OVERHEAD_BYTES

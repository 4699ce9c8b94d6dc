"""The in-memory store: maps and plans in this process, for one uvicorn worker."""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable

import orjson

from planner import RobotMap
from service.errors import InsufficientStorage
from service.stores.base import Cells, Decide, PlanLocks, PlanRecord, Store, T, Update, pack, unpack
from service.tenants import TENANT, scoped

__all__ = ["MemoryStore"]

_Entry = tuple[float, bytes, bytearray, str | None, PlanRecord]


class MemoryStore(Store):
    """Everything in this process: for one uvicorn worker.

    Maps take at most ``max_map_bytes``: a new map evicts the least recently used maps that no
    live plan uses, and is refused (507) when those do not free enough.
    """

    kind = "memory"

    def __init__(
        self,
        *,
        ttl_seconds: float,
        max_map_bytes: int | None = None,
        shares: int = 1,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._ttl = ttl_seconds
        self._clock = clock
        self.max_map_bytes = max_map_bytes
        self.map_bytes = 0
        # Each tenant's maps take at most an equal share: one key cannot evict another's maps.
        self._share = None if max_map_bytes is None else max_map_bytes // max(1, shares)
        self._held: dict[str, int] = {}  # map bytes per tenant
        self._maps: OrderedDict[str, RobotMap] = OrderedDict()  # least recently used first
        self._plans_on: dict[str, int] = {}  # live plans per stored map key
        # Every write puts the plan last with expiry now + ttl, so the order is expiry order.
        # An entry: (expiry, the record as JSON, the trajectory log, its map's key, the record
        # itself: read-only, what a step decides on).
        self._plans: OrderedDict[str, _Entry] = OrderedDict()
        self._locks = PlanLocks()

    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        key = scoped(map_id)
        if key in self._maps:
            self._maps.move_to_end(key)
            return False
        size = _size(robot_map)
        self._make_room(size)
        self._maps[key] = robot_map  # read-only, and never shared with a writer
        self.map_bytes += size
        self._held[TENANT.get()] = self._held.get(TENANT.get(), 0) + size
        return True

    async def get_map(self, map_id: str) -> RobotMap | None:
        key = scoped(map_id)
        robot_map = self._maps.get(key)
        if robot_map is not None:
            self._maps.move_to_end(key)
        return robot_map

    async def counts(self) -> tuple[int, int]:
        self._expire()
        return len(self._maps), len(self._plans)

    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        self._expire()
        self._write(scoped(plan_id), orjson.loads(orjson.dumps(record)), append)  # its own copy

    async def update_plan(self, plan_id: str, decide: Decide[T]) -> Update[T] | None:
        key = scoped(plan_id)
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
            return update

    def _write(self, key: str, record: PlanRecord, append: Cells) -> None:
        entry = self._plans.get(key)
        if entry is None:
            map_key = scoped(record["map_id"]) if "map_id" in record else None
            if map_key is not None:
                self._plans_on[map_key] = self._plans_on.get(map_key, 0) + 1
            log = bytearray()
        else:
            log, map_key = entry[2], entry[3]
        log += pack(append)  # in place: appending costs what it appends
        # Serialised like a networked store would (a record that is not JSON fails here); a
        # record is handed out as a copy (get_plan) or read-only (update_plan).
        self._plans[key] = (self._clock() + self._ttl, orjson.dumps(record), log, map_key, record)
        self._plans.move_to_end(key)
        if map_key is not None and map_key in self._maps:
            self._maps.move_to_end(map_key)

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

    def _make_room(self, size: int) -> None:
        limit, share = self.max_map_bytes, self._share
        if limit is None or share is None:
            return
        tenant = TENANT.get()
        if size > share:
            msg = f"a map of {size} bytes is over this key's share of PLANNER_MAP_STORE_BYTES "
            raise InsufficientStorage(msg + f"({share} of {limit})", field="map")
        # The tenant's own idle maps, least recently used first, until it is within its share;
        # then anyone's idle maps until all are within the whole bound. Nothing is evicted when
        # that would not make room.
        own = [k for k in self._maps if _owner(k) == tenant and not self._plans_on.get(k)]
        over = self._held.get(tenant, 0) + size - share
        if over > sum(_size(self._maps[k]) for k in own):
            raise self._full(limit)
        self._evict(own, over)
        idle = [k for k in self._maps if not self._plans_on.get(k)]
        over = self.map_bytes + size - limit
        if over > sum(_size(self._maps[k]) for k in idle):
            raise self._full(limit)
        self._evict(idle, over)

    def _evict(self, keys: list[str], over: int) -> None:
        """Drop maps of ``keys`` in order until ``over`` bytes are freed."""
        for key in keys:
            if over <= 0:
                return
            size = _size(self._maps.pop(key))
            over -= size
            self.map_bytes -= size
            self._held[_owner(key)] -= size

    @staticmethod
    def _full(limit: int) -> InsufficientStorage:
        msg = (
            f"the map store is full: PLANNER_MAP_STORE_BYTES ({limit}) is taken by maps that "
            "live plans use; delete plans or retry when they expire"
        )
        return InsufficientStorage(msg, field="map")

    def _forget(self, key: str) -> bool:
        entry = self._plans.pop(key, None)
        if entry is None:
            return False
        map_key = entry[3]
        if map_key is not None:
            left = self._plans_on.get(map_key, 1) - 1
            if left:
                self._plans_on[map_key] = left
            else:
                self._plans_on.pop(map_key, None)
        return True

    def _expire(self) -> None:
        now = self._clock()
        while self._plans:
            key, entry = next(iter(self._plans.items()))
            if entry[0] > now:
                break
            self._forget(key)


def _owner(key: str) -> str:
    """The tenant of a stored map key (``""`` without keys): map ids themselves hold no dot."""
    return key.split(".", 1)[0] if "." in key else ""


def _size(robot_map: RobotMap) -> int:
    """The bytes a stored map holds: one per cell (and a zoned map's zones)."""
    zones = 0 if robot_map.zones is None else len(repr(robot_map.zones))
    return int(robot_map.occupancy.nbytes) + zones

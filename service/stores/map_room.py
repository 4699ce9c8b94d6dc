"""The memory store's maps within its byte bound: each map kept with its size, and the idle ones
(no live plan uses them) in least-recently-used order, each tenant's and everyone's, so that
storing a map costs what it evicts, whatever the number of maps and tenants."""

from __future__ import annotations

from collections import OrderedDict
from typing import NamedTuple

from planner import RobotMap
from service.errors import InsufficientStorage

__all__ = ["MapRoom"]


class _Map(NamedTuple):
    robot_map: RobotMap
    size: int
    tenant: str


class MapRoom:
    """Maps by key, at most ``max_bytes`` of them in all and ``max_bytes // shares`` for each
    tenant (None: no bound). A new map evicts the tenant's own least recently used idle maps
    until the tenant is within its share, then anyone's until all are within the bound; it is
    refused (507) when those would not free enough. A map is idle while no live plan uses it
    (:meth:`use`, :meth:`leave`); a map its last plan left is as recently used as that."""

    def __init__(self, max_bytes: int | None, *, shares: int = 1) -> None:
        self.max_bytes = max_bytes
        self.share = None if max_bytes is None else max_bytes // max(1, shares)
        self.bytes = 0
        self._maps: dict[str, _Map] = {}
        self._held: dict[str, int] = {}  # bytes per tenant
        self._plans_on: dict[str, int] = {}  # live plans per map key
        # Idle maps, least recently used first: everyone's and each tenant's, with their bytes.
        self._idle: OrderedDict[str, None] = OrderedDict()
        self._idle_of: dict[str, OrderedDict[str, None]] = {}
        self._idle_bytes = 0
        self._idle_held: dict[str, int] = {}

    def __len__(self) -> int:
        return len(self._maps)

    def __contains__(self, key: str) -> bool:
        return key in self._maps

    def get(self, key: str) -> RobotMap | None:
        """The map of ``key``, now the most recently used; None when not stored."""
        entry = self._maps.get(key)
        if entry is None:
            return None
        self.touch(key)
        return entry.robot_map

    def touch(self, key: str) -> None:
        """Count a use of the map of ``key`` (if stored and idle: now the last to evict)."""
        if key in self._idle:
            self._idle.move_to_end(key)
            self._idle_of[self._maps[key].tenant].move_to_end(key)

    def put(self, key: str, robot_map: RobotMap, *, size: int, tenant: str) -> None:
        """Store a new map of ``size`` bytes for ``tenant``, evicting idle maps to make room
        (``InsufficientStorage`` when they cannot)."""
        self._make_room(size, tenant)
        self._maps[key] = _Map(robot_map, size, tenant)
        self.bytes += size
        self._held[tenant] = self._held.get(tenant, 0) + size
        if not self._plans_on.get(key):
            self._set_idle(key)

    def use(self, key: str) -> None:
        """A live plan on the map of ``key`` more: the map is not evicted while one is."""
        count = self._plans_on.get(key, 0)
        self._plans_on[key] = count + 1
        if not count and key in self._idle:
            self._unset_idle(key)

    def leave(self, key: str) -> None:
        """A live plan on the map of ``key`` less (expired or deleted)."""
        count = self._plans_on.get(key, 1) - 1
        if count:
            self._plans_on[key] = count
            return
        self._plans_on.pop(key, None)
        if key in self._maps:
            self._set_idle(key)

    def _set_idle(self, key: str) -> None:
        entry = self._maps[key]
        self._idle[key] = None
        self._idle_of.setdefault(entry.tenant, OrderedDict())[key] = None
        self._idle_bytes += entry.size
        self._idle_held[entry.tenant] = self._idle_held.get(entry.tenant, 0) + entry.size

    def _unset_idle(self, key: str) -> None:
        entry = self._maps[key]
        del self._idle[key]
        own = self._idle_of[entry.tenant]
        del own[key]
        if not own:
            del self._idle_of[entry.tenant]
        self._idle_bytes -= entry.size
        self._idle_held[entry.tenant] -= entry.size

    def _make_room(self, size: int, tenant: str) -> None:
        limit, share = self.max_bytes, self.share
        if limit is None or share is None:
            return
        if size > share:
            msg = f"a map of {size} bytes is over this key's share of PLANNER_MAP_STORE_BYTES "
            raise InsufficientStorage(msg + f"({share} of {limit})", field="map")
        # Nothing is evicted when that would not make room.
        over = self._held.get(tenant, 0) + size - share
        if over > self._idle_held.get(tenant, 0):
            raise _full(limit)
        while over > 0:
            over -= self._evict(next(iter(self._idle_of[tenant])))
        over = self.bytes + size - limit
        if over > self._idle_bytes:
            raise _full(limit)
        while over > 0:
            over -= self._evict(next(iter(self._idle)))

    def _evict(self, key: str) -> int:
        """Drop an idle map: its bytes."""
        self._unset_idle(key)
        entry = self._maps.pop(key)
        self.bytes -= entry.size
        self._held[entry.tenant] -= entry.size
        return entry.size


def _full(limit: int) -> InsufficientStorage:
    msg = (
        f"the map store is full: PLANNER_MAP_STORE_BYTES ({limit}) is taken by maps that "
        "live plans use; delete plans or retry when they expire"
    )
    return InsufficientStorage(msg, field="map")

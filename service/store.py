"""Where maps and plans live: the ``Store`` interface, the in-memory store, ``open_store``.

A plan is kept as plain JSON data (its inputs and ``SessionState.as_dict()``), never as arrays,
so a networked store (``service/redis_store.py``) can hold it; the arrays are rebuilt from the
cached analysis and wave.
"""

from __future__ import annotations

import asyncio
import time
from abc import ABC, abstractmethod
from collections import OrderedDict
from collections.abc import AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from typing import Any

import numpy as np
import numpy.typing as npt
import orjson

__all__ = ["MemoryStore", "PlanRecord", "Store", "open_store"]

Grid = npt.NDArray[np.uint8]
PlanRecord = dict[str, Any]


class Store(ABC):
    """Maps by ``map_id`` (kept) and plans by ``plan_id`` (forgotten after a TTL).

    A store that cannot answer raises :class:`service.errors.StoreUnavailable`, never its
    client's own errors.
    """

    kind: str

    @abstractmethod
    async def put_map(self, map_id: str, grid: Grid) -> bool:
        """Keep a map; True when it was not known before."""

    @abstractmethod
    async def get_map(self, map_id: str) -> Grid | None:
        """The map's 0/1 grid (read-only), or None."""

    @abstractmethod
    async def put_plan(self, plan_id: str, record: PlanRecord) -> None:
        """Keep (or replace) a plan's record; restarts its TTL."""

    @abstractmethod
    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        """A copy of the plan's record, or None when unknown, deleted or expired."""

    @abstractmethod
    async def delete_plan(self, plan_id: str) -> bool:
        """Forget a plan; True when it existed."""

    @abstractmethod
    def plan_lock(self, plan_id: str) -> AbstractAsyncContextManager[None]:
        """An async context manager held while a plan is read, stepped and written back."""

    async def check(self) -> str | None:
        """None when the store answers, else why it does not (for ``/healthz``)."""
        return None

    async def close(self) -> None:  # noqa: B027 - a store with nothing to release keeps this
        """Release connections."""


class MemoryStore(Store):
    """Everything in this process: for one uvicorn worker."""

    kind = "memory"

    def __init__(self, *, ttl_seconds: float, clock: Callable[[], float] = time.monotonic) -> None:
        self._ttl = ttl_seconds
        self._clock = clock
        self._maps: dict[str, Grid] = {}
        # Every write puts the plan last with expiry now + ttl, so the order is expiry order.
        self._plans: OrderedDict[str, tuple[float, bytes]] = OrderedDict()
        self._locks: dict[str, asyncio.Lock] = {}

    async def put_map(self, map_id: str, grid: Grid) -> bool:
        if map_id in self._maps:
            return False
        grid = grid.copy()
        grid.flags.writeable = False
        self._maps[map_id] = grid
        return True

    async def get_map(self, map_id: str) -> Grid | None:
        return self._maps.get(map_id)

    async def put_plan(self, plan_id: str, record: PlanRecord) -> None:
        self._expire()
        # Serialised like a networked store would, so a record never shares state with a caller.
        self._plans[plan_id] = (self._clock() + self._ttl, orjson.dumps(record))
        self._plans.move_to_end(plan_id)

    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        self._expire()
        entry = self._plans.get(plan_id)
        return None if entry is None else dict(orjson.loads(entry[1]))

    async def delete_plan(self, plan_id: str) -> bool:
        self._locks.pop(plan_id, None)
        return self._plans.pop(plan_id, None) is not None

    @asynccontextmanager
    async def plan_lock(self, plan_id: str) -> AsyncIterator[None]:
        lock = self._locks.setdefault(plan_id, asyncio.Lock())
        async with lock:
            yield

    def _expire(self) -> None:
        now = self._clock()
        while self._plans:
            plan_id, (expires, _) = next(iter(self._plans.items()))
            if expires > now:
                break
            del self._plans[plan_id]
            self._locks.pop(plan_id, None)


def open_store(url: str, *, ttl_seconds: float) -> Store:
    """The store that ``PLANNER_STORE_URL`` names: ``memory://`` or a ``redis://`` URL."""
    if url.startswith("memory://"):
        return MemoryStore(ttl_seconds=ttl_seconds)
    # Imported here: the Redis store builds on this module's interface.
    from service.redis_store import RedisStore

    return RedisStore(url, ttl_seconds=ttl_seconds)

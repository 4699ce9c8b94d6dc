"""Where maps and plans live: the ``Store`` interface, the in-memory store, ``open_store``.

A plan is kept as plain JSON data (its inputs and ``SessionState.as_dict()`` less the
trajectory), never as arrays, so a networked store (``service/redis_store.py``) can hold it; the
arrays are rebuilt from the cached analysis and wave. The trajectory, which grows with every
move, is kept beside the record as an append-only log of packed cells: a step rewrites a record
of constant size and appends a cell, whatever the length of the episode.
"""

from __future__ import annotations

import asyncio
import time
from abc import ABC, abstractmethod
from collections import OrderedDict
from collections.abc import AsyncIterator, Callable, Sequence
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from typing import Any

import numpy as np
import numpy.typing as npt
import orjson

__all__ = ["Cells", "MemoryStore", "PlanRecord", "Store", "open_store", "pack", "unpack"]

Grid = npt.NDArray[np.uint8]
PlanRecord = dict[str, Any]
Cells = Sequence[Sequence[int]]


def pack(cells: Cells) -> bytes:
    """Cells as little-endian int32 pairs: the trajectory log's format, in every store."""
    return np.asarray(cells, dtype="<i4").reshape(-1, 2).tobytes()


def unpack(data: bytes) -> list[tuple[int, int]]:
    """The cells of a trajectory log, in order."""
    return list(map(tuple, np.frombuffer(data, dtype="<i4").reshape(-1, 2).tolist()))


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
    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        """Keep (or replace) a plan's record and add ``append`` to its trajectory, both at once;
        restarts the plan's TTL."""

    @abstractmethod
    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        """A copy of the plan's record, or None when unknown, deleted or expired."""

    @abstractmethod
    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        """Every cell appended to the plan's trajectory, in order (none for an unknown plan)."""

    @abstractmethod
    async def delete_plan(self, plan_id: str) -> bool:
        """Forget a plan; True when it existed."""

    @abstractmethod
    def plan_lock(self, plan_id: str) -> AbstractAsyncContextManager[None]:
        """An async context manager held while a plan is read, stepped and written back."""

    @abstractmethod
    async def counts(self) -> tuple[int, int]:
        """How many maps and how many live plans the store holds (for ``/metrics``)."""

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
        # An entry: (expiry, the record as JSON, the trajectory log).
        self._plans: OrderedDict[str, tuple[float, bytes, bytearray]] = OrderedDict()
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


def open_store(url: str, *, ttl_seconds: float) -> Store:
    """The store that ``PLANNER_STORE_URL`` names: ``memory://`` or a ``redis://`` URL."""
    if url.startswith("memory://"):
        return MemoryStore(ttl_seconds=ttl_seconds)
    # Imported here: the Redis store builds on this module's interface.
    from service.redis_store import RedisStore

    return RedisStore(url, ttl_seconds=ttl_seconds)

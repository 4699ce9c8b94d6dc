"""A least-recently-used cache bounded in bytes, where concurrent misses on a key compute once."""

from __future__ import annotations

import asyncio
from collections import OrderedDict
from collections.abc import Awaitable, Callable, Hashable
from typing import Any, Protocol, TypeVar, cast

__all__ = ["ByteLRU", "Sized"]


class Sized(Protocol):
    @property
    def nbytes(self) -> int: ...


T = TypeVar("T", bound=Sized)


class ByteLRU:
    """Values that know their ``nbytes``, at most ``max_bytes`` of them in all.

    >>> import asyncio, numpy as np
    >>> cache = ByteLRU(max_bytes=100)
    >>> async def compute() -> np.ndarray: return np.zeros(10, dtype=np.uint8)
    >>> value, hit = asyncio.run(cache.get_or_compute("a", compute))
    >>> hit, cache.bytes
    (False, 10)
    """

    def __init__(self, max_bytes: int) -> None:
        self.max_bytes = max_bytes
        self.bytes = 0
        self.hits = self.misses = self.evictions = 0
        self._entries: OrderedDict[Hashable, tuple[Any, int]] = OrderedDict()
        self._pending: dict[Hashable, asyncio.Future[Any]] = {}

    def __len__(self) -> int:
        return len(self._entries)

    async def get_or_compute(
        self, key: Hashable, compute: Callable[[], Awaitable[T]]
    ) -> tuple[T, bool]:
        """The value for ``key`` and whether this call found it (True) or computed it (False).

        A call arriving while another computes the same key waits for that result (and counts
        as a hit); a failed computation is not cached, and every waiter gets its error.
        """
        entry = self._entries.get(key)
        if entry is not None:
            self._entries.move_to_end(key)
            self.hits += 1
            return cast(T, entry[0]), True
        pending = self._pending.get(key)
        hit = pending is not None
        if pending is None:
            self.misses += 1
            pending = asyncio.ensure_future(self._fill(key, compute))
            # Errors reach the callers; this only keeps a task nobody awaits any more quiet.
            pending.add_done_callback(lambda f: f.cancelled() or f.exception())
            self._pending[key] = pending
        else:
            self.hits += 1
        # Shielded: a caller that gives up (a client gone) must not cancel the others' result.
        return cast(T, await asyncio.shield(pending)), hit

    async def _fill(self, key: Hashable, compute: Callable[[], Awaitable[Sized]]) -> Sized:
        try:
            value = await compute()
            self._insert(key, value, int(value.nbytes))
            return value
        finally:
            del self._pending[key]

    def _insert(self, key: Hashable, value: Any, size: int) -> None:
        if size > self.max_bytes:
            return
        self._entries[key] = (value, size)
        self.bytes += size
        while self.bytes > self.max_bytes:
            _, (_, old) = self._entries.popitem(last=False)
            self.bytes -= old
            self.evictions += 1

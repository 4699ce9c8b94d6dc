"""A least-recently-used cache bounded in bytes, where concurrent misses on a key compute once,
from the event loop or from worker threads alike."""

from __future__ import annotations

import asyncio
import logging
import threading
from collections import OrderedDict
from collections.abc import Awaitable, Callable, Hashable
from concurrent.futures import Future
from typing import Any, Protocol, TypeVar, cast

from service.tenants import TENANT

__all__ = ["ByteLRU", "Sized"]

logger = logging.getLogger(__name__)


class Sized(Protocol):
    @property
    def nbytes(self) -> int: ...


T = TypeVar("T", bound=Sized)


class ByteLRU:
    """Values that know their ``nbytes``, at most ``max_bytes`` of them in all, and at most
    ``max_bytes // shares`` for each tenant (:mod:`service.tenants`): a tenant over its share
    evicts its own least recently used entries, never another tenant's.

    >>> import asyncio, numpy as np
    >>> cache = ByteLRU(max_bytes=100)
    >>> async def compute() -> np.ndarray: return np.zeros(10, dtype=np.uint8)
    >>> value, hit = asyncio.run(cache.get_or_compute("a", compute))
    >>> hit, cache.bytes, cache.peek("a") is value
    (False, 10, True)
    """

    def __init__(
        self,
        max_bytes: int,
        *,
        shares: int = 1,
        on_evict: Callable[[Hashable, Any], None] | None = None,
    ) -> None:
        self.max_bytes = max_bytes
        self.on_evict = on_evict
        """Called with each evicted key and value once the eviction is complete and the cache's
        lock released (it may use the cache); what it raises is logged, not raised to the caller
        whose insert made the room."""
        self.share = max_bytes // max(1, shares)
        self.bytes = 0
        self.hits = self.misses = self.evictions = 0
        # An entry: (value, its bytes, its tenant); the bytes each tenant holds beside.
        self._entries: OrderedDict[Hashable, tuple[Any, int, str]] = OrderedDict()
        self._held: dict[str, int] = {}
        self._pending: dict[Hashable, Future[Any]] = {}
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._entries)

    def peek(self, key: Hashable) -> Any | None:
        """The value for ``key`` if it is cached now (counted as a hit), else None."""
        with self._lock:
            entry = self._entries.get(key)
            if entry is None:
                return None
            self._entries.move_to_end(key)
            self.hits += 1
            return entry[0]

    def touch(self, *keys: Hashable) -> None:
        """Count a use of the entries of ``keys`` that the caller found elsewhere (a memo of
        what is built over them): each one present is a hit, now the most recently used."""
        with self._lock:
            for key in keys:
                if key in self._entries:
                    self._entries.move_to_end(key)
                    self.hits += 1

    def recharge(self, key: Hashable, value: Sized) -> None:
        """Measure ``value`` again if it is still the entry of ``key``: a value that grew (or
        shrank) in place is charged what it holds now, and least recently used entries make
        room as on insert (the value itself goes when it no longer fits its tenant's share).

        >>> import numpy as np
        >>> cache = ByteLRU(max_bytes=100)
        >>> grows = np.zeros(10, dtype=np.uint8)
        >>> _ = cache.get_or_compute_sync("a", lambda: grows)
        >>> grows.resize(60, refcheck=False); cache.recharge("a", grows); cache.bytes
        60
        """
        new = int(value.nbytes)
        evicted: list[tuple[Hashable, Any]] = []
        with self._lock:
            entry = self._entries.get(key)
            if entry is None or entry[0] is not value:
                return
            _, size, tenant = entry
            if new == size:
                return
            self._entries[key] = (value, new, tenant)
            self.bytes += new - size
            self._held[tenant] += new - size
            if new > self.share:
                self._evict(key, evicted)
            else:
                if self._held[tenant] > self.share:
                    own = [k for k, e in self._entries.items() if e[2] == tenant and k != key]
                    for old in own:
                        self._evict(old, evicted)
                        if self._held[tenant] <= self.share:
                            break
                while self.bytes > self.max_bytes:
                    self._evict(next(iter(self._entries)), evicted)
        self._tell(evicted)

    def discard(self, key: Hashable) -> None:
        """Drop the entry of ``key`` if there is one, as an eviction (``on_evict`` is told)."""
        evicted: list[tuple[Hashable, Any]] = []
        with self._lock:
            if key in self._entries:
                self._evict(key, evicted)
        self._tell(evicted)

    async def get_or_compute(
        self, key: Hashable, compute: Callable[[], Awaitable[T]]
    ) -> tuple[T, bool]:
        """The value for ``key`` and whether this call found it (True) or computed it (False).

        A call arriving while another computes the same key waits for that result (and counts
        as a hit); a failed computation is not cached, and every waiter gets its error.
        """
        value, future, owner = self._claim(key)
        if future is None:
            return cast(T, value), True
        if owner:
            task = asyncio.ensure_future(self._fill(key, compute, future))
            # Errors reach the callers through the future; this keeps the task itself quiet.
            task.add_done_callback(lambda t: t.cancelled() or t.exception())
        # Shielded: a caller that gives up (a client gone) must not cancel the others' result.
        return cast(T, await asyncio.shield(asyncio.wrap_future(future))), not owner

    def get_or_compute_sync(self, key: Hashable, compute: Callable[[], T]) -> tuple[T, bool]:
        """:meth:`get_or_compute` for a worker thread: ``compute`` runs in the calling thread."""
        value, future, owner = self._claim(key)
        if future is None:
            return cast(T, value), True
        if not owner:
            return cast(T, future.result()), True
        try:
            result = compute()
        except BaseException as exc:
            self._settle(key, future, error=exc)
            raise
        self._settle(key, future, value=result)
        return result, False

    def _claim(self, key: Hashable) -> tuple[Any, Future[Any] | None, bool]:
        """(cached value, None, False), or (None, the computation's future, whether to run it)."""
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None:
                self._entries.move_to_end(key)
                self.hits += 1
                return entry[0], None, False
            future = self._pending.get(key)
            if future is not None:
                self.hits += 1
                return None, future, False
            self.misses += 1
            future = self._pending[key] = Future()
            return None, future, True

    async def _fill(
        self, key: Hashable, compute: Callable[[], Awaitable[Sized]], future: Future[Any]
    ) -> None:
        try:
            value = await compute()
        except BaseException as exc:
            self._settle(key, future, error=exc)
            raise
        self._settle(key, future, value=value)

    def _settle(
        self,
        key: Hashable,
        future: Future[Any],
        *,
        value: Sized | None = None,
        error: BaseException | None = None,
    ) -> None:
        """Cache the result (the key no longer pending) and hand it, or the error, to every
        waiter: the future is settled whatever happens here, so that no waiter hangs."""
        evicted: list[tuple[Hashable, Any]] = []
        try:
            with self._lock:
                del self._pending[key]
                if error is None:
                    assert value is not None
                    self._insert(key, value, int(value.nbytes), evicted)
        finally:
            if error is None:
                future.set_result(value)
            else:
                future.set_exception(error)
        self._tell(evicted)

    def _insert(
        self, key: Hashable, value: Any, size: int, evicted: list[tuple[Hashable, Any]]
    ) -> None:
        if size > self.share:
            return
        tenant = TENANT.get()
        if self._held.get(tenant, 0) + size > self.share:
            for old in [k for k, e in self._entries.items() if e[2] == tenant]:
                self._evict(old, evicted)
                if self._held.get(tenant, 0) + size <= self.share:
                    break
        self._entries[key] = (value, size, tenant)
        self.bytes += size
        self._held[tenant] = self._held.get(tenant, 0) + size
        while self.bytes > self.max_bytes:
            self._evict(next(iter(self._entries)), evicted)

    def _evict(self, key: Hashable, evicted: list[tuple[Hashable, Any]]) -> None:
        """Drop an entry (the lock held); ``on_evict`` is told of it after (:meth:`_tell`)."""
        value, size, tenant = self._entries.pop(key)
        self.bytes -= size
        self._held[tenant] -= size
        self.evictions += 1
        evicted.append((key, value))

    def _tell(self, evicted: list[tuple[Hashable, Any]]) -> None:
        """``on_evict`` of each evicted entry, the lock released: the cache is whole whatever
        it does, and an error of one is logged, the others still told."""
        on_evict = self.on_evict
        if on_evict is None:
            return
        for key, value in evicted:
            try:
                on_evict(key, value)
            except Exception:
                logger.exception("on_evict failed for an evicted cache entry")

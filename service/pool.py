"""The worker pool that runs planner kernels off the event loop.

Threads, not processes: the numba kernels release the GIL (``nogil=True``), so threads run them
in parallel while sharing the cached arrays without copying or pickling them
(``benchmarks/pool.py`` measures both).
"""

from __future__ import annotations

import asyncio
import functools
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import ParamSpec, TypeVar

__all__ = ["Pool"]

P = ParamSpec("P")
R = TypeVar("R")


class Pool:
    """At most ``size`` planner calls at once; the rest wait their turn without blocking."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.busy = 0
        """Calls running now (``/metrics``)."""
        self.queued = 0
        """Calls waiting for a free worker (``/metrics``)."""
        self.warm = False
        """Whether the kernels are compiled (set by the app's lifespan; ``/readyz``)."""
        self._counts = threading.Lock()
        self._executor = ThreadPoolExecutor(max_workers=size, thread_name_prefix="planner")

    async def run(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> R:
        with self._counts:
            self.queued += 1
        future = self._executor.submit(self._call, functools.partial(fn, *args, **kwargs))
        # A call cancelled before it started (its client gone) never reaches _call.
        future.add_done_callback(self._dequeue_cancelled)
        return await asyncio.wrap_future(future)

    def _call(self, call: Callable[[], R]) -> R:
        with self._counts:
            self.queued -= 1
            self.busy += 1
        try:
            return call()
        finally:
            with self._counts:
                self.busy -= 1

    def _dequeue_cancelled(self, future: Future[R]) -> None:
        if future.cancelled():
            with self._counts:
                self.queued -= 1

    def close(self) -> None:
        self._executor.shutdown(wait=True, cancel_futures=True)

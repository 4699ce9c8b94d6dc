"""The worker pools that run planner kernels off the event loop.

Threads, not processes: the numba kernels release the GIL (``nogil=True``), so threads run them
in parallel while sharing the cached arrays without copying or pickling them
(``benchmarks/pool.py`` measures both).

Two pools: heavy jobs (analyses, plans, renders, simulations) share ``size`` workers and a
bounded queue, beyond which they are refused with 503 at once; steps that replan have workers of
their own, so a client stepping a robot never waits behind another client's analyses
(``benchmarks/fairness.py`` measures it).
"""

from __future__ import annotations

import asyncio
import contextvars
import functools
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import ParamSpec, TypeVar

from service.errors import Busy

__all__ = ["Pool"]

P = ParamSpec("P")
R = TypeVar("R")


class Pool:
    """At most ``size`` heavy planner calls at once and ``max_queued`` more waiting their turn
    (without blocking); steps on ``step_size`` workers of their own."""

    def __init__(self, size: int, *, step_size: int = 1, max_queued: int | None = None) -> None:
        self.size = size
        self.max_queued = max_queued
        self.jobs = 0  # heavy jobs running or waiting, as their callers see them
        self.running = 0  # calls running in a worker now (a cancelled caller's may go on)
        self._count = threading.Lock()
        self._executor = ThreadPoolExecutor(max_workers=size, thread_name_prefix="planner")
        self._steps = ThreadPoolExecutor(max_workers=step_size, thread_name_prefix="step")

    async def run(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> R:
        """``fn`` on a heavy worker; :class:`Busy` (503) when the queue is full."""
        if self.max_queued is not None and self.jobs >= self.size + self.max_queued:
            msg = (
                f"the service is busy: {self.jobs} heavy jobs are running or queued "
                f"(PLANNER_MAX_QUEUED_JOBS is {self.max_queued}); retry later"
            )
            raise Busy(msg)
        self.jobs += 1
        try:
            return await self._on(self._executor, self._counted, fn, *args, **kwargs)
        finally:
            self.jobs -= 1

    async def run_step(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> R:
        """``fn`` on a step worker: never queued behind heavy jobs."""
        return await self._on(self._steps, fn, *args, **kwargs)

    def _counted(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> R:
        with self._count:
            self.running += 1
        try:
            return fn(*args, **kwargs)
        finally:
            with self._count:
                self.running -= 1

    @staticmethod
    async def _on(
        executor: ThreadPoolExecutor, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs
    ) -> R:
        loop = asyncio.get_running_loop()
        # The caller's context goes along: the worker's cache entries count for its tenant.
        call = functools.partial(contextvars.copy_context().run, fn, *args, **kwargs)
        return await loop.run_in_executor(executor, call)

    def close(self) -> None:
        self._executor.shutdown(wait=True, cancel_futures=True)
        self._steps.shutdown(wait=True, cancel_futures=True)

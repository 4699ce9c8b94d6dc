"""The worker pools that run planner kernels off the event loop: threads (the kernels release
the GIL and share the cached arrays); heavy jobs wait on a bounded queue, fair between tenants
(one tenant never holds every worker), replanning steps have workers of their own."""

from __future__ import annotations

import asyncio
import contextvars
import functools
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import ParamSpec, TypeVar

from service.errors import Busy
from service.tenants import TENANT

__all__ = ["Pool"]

P = ParamSpec("P")
R = TypeVar("R")


class Pool:
    """At most ``size`` heavy planner calls at once and ``max_queued`` more waiting their turn
    (without blocking); steps on ``step_size`` workers of their own. With ``tenants`` (API keys),
    one tenant's heavy calls hold at most ``size - 1`` workers at once (the rest of its calls
    wait in its own turn), and at most half the queue: another tenant always finds a worker."""

    def __init__(
        self,
        size: int,
        *,
        step_size: int = 1,
        max_queued: int | None = None,
        tenants: bool = False,
    ) -> None:
        self.size = size
        self.max_queued = max_queued
        self.fair = tenants
        self.share = max(1, size - 1) if tenants else size
        """Workers one tenant's heavy calls may hold at once."""
        self._turns: dict[str, tuple[asyncio.Semaphore, int]] = {}  # a tenant's, its users
        self.jobs = 0
        """Heavy jobs running or waiting, as their callers see them (the queue's bound)."""
        self.busy = 0
        """Heavy calls running in a worker now, a cancelled caller's included (``/metrics``)."""
        self.queued = 0
        """Heavy calls waiting for a free worker (``/metrics``)."""
        self.warm = False
        """Whether every kernel is compiled (set by the app's lifespan; ``/readyz``)."""
        self.serving = False
        """Whether the warm-up ended or had its time (``PLANNER_WARMUP_WAIT_SECONDS``): the
        service is ready, the kernels not yet compiled compiling in the background."""
        self._counts = threading.Lock()
        self._executor = ThreadPoolExecutor(max_workers=size, thread_name_prefix="planner")
        self._steps = ThreadPoolExecutor(max_workers=step_size, thread_name_prefix="step")

    async def run(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> R:
        """``fn`` on a heavy worker, in its tenant's turn; :class:`Busy` (503) when the queue,
        or the tenant's half of it, is full."""
        if self.max_queued is not None and self.jobs >= self.size + self.max_queued:
            msg = (
                f"the service is busy: {self.jobs} heavy jobs are running or queued "
                f"(PLANNER_MAX_QUEUED_JOBS is {self.max_queued}); retry later"
            )
            raise Busy(msg)
        call = _in_context(fn, *args, **kwargs)
        if not self.fair:
            self.jobs += 1
            try:
                return await self._submit(call)
            finally:
                self.jobs -= 1
        tenant = TENANT.get()
        turn, users = self._turns.get(tenant, (None, 0))
        if self.max_queued is not None and users >= self.share + max(1, self.max_queued // 2):
            msg = (
                f"the service is busy: this API key has {users} heavy jobs running or queued, "
                f"its share of PLANNER_MAX_QUEUED_JOBS ({self.max_queued}); retry later"
            )
            raise Busy(msg)
        if turn is None:
            turn = asyncio.Semaphore(self.share)
        self._turns[tenant] = (turn, users + 1)
        self.jobs += 1
        with self._counts:
            self.queued += 1  # waiting for its tenant's turn is waiting for a worker too
        waiting = True
        try:
            async with turn:
                with self._counts:
                    self.queued -= 1
                waiting = False
                return await self._submit(call)
        finally:
            if waiting:
                with self._counts:
                    self.queued -= 1
            self.jobs -= 1
            turn, users = self._turns[tenant]
            if users > 1:
                self._turns[tenant] = (turn, users - 1)
            else:
                del self._turns[tenant]

    async def _submit(self, call: Callable[[], R]) -> R:
        with self._counts:
            self.queued += 1
        future = self._executor.submit(self._call, call)
        # A call cancelled before it started (its client gone) never reaches _call.
        future.add_done_callback(self._dequeue_cancelled)
        return await asyncio.wrap_future(future)

    async def run_step(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> R:
        """``fn`` on a step worker: never queued behind heavy jobs."""
        return await asyncio.wrap_future(self._steps.submit(_in_context(fn, *args, **kwargs)))

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
        self._steps.shutdown(wait=True, cancel_futures=True)


def _in_context(fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> Callable[[], R]:
    """``fn(*args, **kwargs)`` to run in the caller's context: a worker's cache entries count
    for the caller's tenant."""
    return functools.partial(contextvars.copy_context().run, fn, *args, **kwargs)

"""The worker pool that runs planner kernels off the event loop.

Threads, not processes: the numba kernels release the GIL (``nogil=True``), so threads run them
in parallel while sharing the cached arrays without copying or pickling them
(``benchmarks/pool.py`` measures both).
"""

from __future__ import annotations

import asyncio
import functools
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import ParamSpec, TypeVar

__all__ = ["Pool"]

P = ParamSpec("P")
R = TypeVar("R")


class Pool:
    """At most ``size`` planner calls at once; the rest wait their turn without blocking."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._executor = ThreadPoolExecutor(max_workers=size, thread_name_prefix="planner")

    async def run(self, fn: Callable[P, R], /, *args: P.args, **kwargs: P.kwargs) -> R:
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(self._executor, functools.partial(fn, *args, **kwargs))

    def close(self) -> None:
        self._executor.shutdown(wait=True, cancel_futures=True)

"""Threads or processes for the worker pool: four 1024 x 1024 analyses (with a goal wave each).

Processes must pickle each map in and every result (the analysis and the wave, ~27 MB per map)
back to the service, where the cache lives; threads share them. Run:
``.venv/bin/python benchmarks/pool.py``; prints wall times and ratios.
"""

from __future__ import annotations

import functools
import os
import statistics
import time
from collections.abc import Callable
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor
from typing import Any

import numpy as np

import planner

SIZE = 1024
JOBS = 4


def job(grid: np.ndarray) -> tuple[planner.Analysis, planner.Wave]:
    analysis = planner.analyse(grid)
    analysis.clearance  # noqa: B018 - part of the work the service does per analysis
    return analysis, planner.goal_wave(analysis, [0, 0])


def run_all(pool: Executor, grids: list[np.ndarray]) -> list[tuple[planner.Analysis, planner.Wave]]:
    return list(pool.map(job, grids))


def maps() -> list[np.ndarray]:
    out = []
    for seed in range(JOBS):
        grid = (np.random.default_rng(seed).random((SIZE, SIZE)) < 0.2).astype(np.uint8)
        grid[0, 0] = 0
        out.append(grid)
    return out


def timed(run: Callable[[], Any], repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e3


def main() -> None:
    grids = maps()
    workers = os.cpu_count() or 1
    job(grids[0][:64, :64].copy())  # compile in this process
    sequential = timed(lambda: [job(g) for g in grids])
    print(f"{JOBS} maps of {SIZE} x {SIZE}, {workers} workers")
    print(f"sequential:      {sequential:7.0f} ms")
    results = {}
    kinds: dict[str, Callable[[], Executor]] = {
        "threads": lambda: ThreadPoolExecutor(workers),
        "processes": lambda: ProcessPoolExecutor(workers),
    }
    for name, make in kinds.items():
        with make() as pool:
            list(pool.map(job, [g[:64, :64].copy() for g in grids]))  # warm every worker
            results[name] = timed(functools.partial(run_all, pool, grids))
        print(f"{name + ':':16} {results[name]:7.0f} ms  speed-up {sequential / results[name]:.2f}")
    print(f"processes / threads: {results['processes'] / results['threads']:.2f}")


if __name__ == "__main__":
    main()

"""What a plan holds, in-process: the peak RSS (sampled every 5 ms) of a first plan across a
4096 x 4096 map with a 3000 x 3000 block in its middle (its analysis, then the plan, bounded by
``max_detour``), and the waves a route through 64 waypoints on a free 1024 x 1024 map keeps.
The service's ``benchmarks/abuse.py`` rows "a first plan on a 4096 x 4096 map" and "M1" measure
the same over HTTP.

Run: ``PYTHONPATH=. .venv/bin/python benchmarks/plan_memory.py [--side 4096]``.
"""

from __future__ import annotations

import argparse
import threading
import time
from pathlib import Path

import numpy as np

import planner


def rss_mb() -> float:
    return int(Path("/proc/self/statm").read_text().split()[1]) * 4096 / 1e6


class Peak:
    """The process's peak RSS since :meth:`reset`, sampled every 5 ms on a thread."""

    def __init__(self) -> None:
        self.value = 0.0
        threading.Thread(target=self._sample, daemon=True).start()

    def _sample(self) -> None:
        while True:
            self.value = max(self.value, rss_mb())
            time.sleep(0.005)

    def reset(self) -> None:
        self.value = rss_mb()


def first_plan(side: int, peak: Peak) -> None:
    block = side * 3000 // 4096
    grid = np.zeros((side, side), dtype=np.uint8)
    edge = (side - block) // 2
    grid[edge : edge + block, edge : edge + block] = 1
    robot_map = planner.grid_map(grid, resolution=0.05)
    params = planner.resolve_params("wide")
    planner.analyse_map(robot_map, params)  # compiled and warm, then let go
    base = rss_mb()
    peak.reset()
    t0 = time.perf_counter()
    analysis = planner.analyse_map(robot_map, params)
    took, top = time.perf_counter() - t0, peak.value
    t0 = time.perf_counter()
    plan = planner.plan(None, [0, 0], [side - 1] * 2, analysis=analysis)
    plan.summary()
    print(
        f"first plan, {side} x {side}: analysis {took:.2f} s, peak +{top - base:.0f} MB; "
        f"plan {time.perf_counter() - t0:.2f} s, peak +{peak.value - base:.0f} MB "
        f"(the wave {plan.wave.nbytes / 1e6:.0f} MB, the analysis {analysis.nbytes / 1e6:.0f} MB)"
    )


def route(peak: Peak) -> None:
    side = 1024
    robot_map = planner.grid_map(np.zeros((side, side), dtype=np.uint8), resolution=0.05)
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide"))
    through = np.random.default_rng(36).integers(0, side, (64, 2)).tolist()
    base = rss_mb()
    peak.reset()
    t0 = time.perf_counter()
    plan = planner.plan(None, [0, 0], [side - 1] * 2, analysis=analysis, waypoints=through)
    plan.path  # noqa: B018
    assert plan.route is not None
    waves = {id(leg.wave): leg.wave for leg in plan.route.legs}.values()
    whole = sum(not (isinstance(w, planner.ResumableWave) and w.resumable) for w in waves)
    print(
        f"64 waypoints, {side} x {side}: {time.perf_counter() - t0:.2f} s, peak "
        f"+{peak.value - base:.0f} MB; {len(waves)} waves hold "
        f"{sum(w.nbytes for w in waves) / 1e6:.0f} MB, {whole} of them whole-map ones"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=int, default=4096, help="the first plan's map side")
    args = parser.parse_args()
    peak = Peak()
    first_plan(args.side, peak)
    route(peak)


if __name__ == "__main__":
    main()

"""The exact distance transform, side by side in one run: the planner's numba kernel
(``planner.analysis.distance.squared_distances``) against the ``edt`` package and scipy's
``distance_transform_edt``, each run on a worker thread while the main thread ticks every
5 ms: the time it takes, and the longest the ticks waited (how long it held the GIL, so how
long a service's event loop would have waited)::

    .venv/bin/python benchmarks/distance.py               # 4096 x 4096 maps, 3 rounds
    .venv/bin/python benchmarks/distance.py --side 2048 --rounds 5 --no-scipy
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import threading
import time
from collections.abc import Callable

import edt
import numpy as np
from abuse_heavy import rooms
from common import ROOT
from scipy import ndimage

sys.path.insert(0, str(ROOT))

from planner.analysis.distance import squared_distances

TICK_SECONDS = 0.005


def maps(side: int) -> dict[str, np.ndarray]:
    """Free cells (True) of three maps ``side`` cells a side: a block in the middle (abuse.py's
    first plan), rooms with doors (abuse.py's passages), 10 % of cells blocked at random."""
    block = np.ones((side, side), dtype=bool)
    edge = side // 8
    block[edge:-edge, edge:-edge] = False
    scattered = np.random.default_rng(0).random((side, side)) >= 0.1
    return {
        "a block in the middle": block,
        "rooms": ~rooms(side),
        "10 % at random": scattered,
    }


def transforms(scipy: bool) -> dict[str, Callable[[np.ndarray], np.ndarray]]:
    """Each library's squared distances, the outside of the map blocked (as the analysis has)."""

    def padded_scipy(free: np.ndarray) -> np.ndarray:
        distance: np.ndarray = ndimage.distance_transform_edt(np.pad(free, 1))
        squared: np.ndarray = np.rint(distance[1:-1, 1:-1] ** 2)
        return squared

    chosen: dict[str, Callable[[np.ndarray], np.ndarray]] = {
        "planner (numba)": lambda free: squared_distances(free, outside_blocked=True),
        "edt": lambda free: edt.edtsq(free, black_border=True).astype(np.float64),
    }
    if scipy:
        chosen["scipy.ndimage"] = padded_scipy
    return chosen


def timed(transform: Callable[[np.ndarray], np.ndarray], free: np.ndarray) -> tuple[float, float]:
    """Seconds the transform took on a worker thread, and the longest wait of a 5 ms tick on
    this thread meanwhile (seconds)."""
    done = threading.Event()
    took = [0.0]

    def work() -> None:
        t0 = time.perf_counter()
        transform(free)
        took[0] = time.perf_counter() - t0
        done.set()

    worker = threading.Thread(target=work)
    last, stall = time.perf_counter(), 0.0
    worker.start()
    while not done.is_set():
        time.sleep(TICK_SECONDS)
        now = time.perf_counter()
        stall = max(stall, now - last - TICK_SECONDS)
        last = now
    worker.join()
    return took[0], stall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("::")[0])
    parser.add_argument("--side", type=int, default=4096)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-scipy", action="store_true", help="skip scipy (4x slower)")
    args = parser.parse_args()
    chosen = transforms(scipy=not args.no_scipy)
    small = maps(64)["rooms"]
    reference = chosen["edt"](small)
    for name, transform in chosen.items():  # compiled, and all agree, before any timing
        assert np.array_equal(transform(small), reference), name
    print(f"{args.side} x {args.side} cells, {args.rounds} rounds, load {os.getloadavg()[0]:.1f}")
    print("| map | transform | seconds (median) | longest GIL hold (s, max) |")
    print("|---|---|---:|---:|")
    for map_name, free in maps(args.side).items():
        results: dict[str, list[tuple[float, float]]] = {name: [] for name in chosen}
        for _ in range(args.rounds):  # alternated, so that the machine's phases fall on each
            for name, transform in chosen.items():
                results[name].append(timed(transform, free))
        for name, runs in results.items():
            took = statistics.median(t for t, _ in runs)
            stall = max(s for _, s in runs)
            print(f"| {map_name} | {name} | {took:.2f} | {stall:.3f} |")
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()

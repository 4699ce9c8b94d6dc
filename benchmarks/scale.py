"""Benchmarks at scale (issue 14): near and far plans on a 4096 x 4096 map and the memory a plan
keeps, the analysis and the upload of a 4096 x 4096 map against the equivalent numpy / scipy
operations (the whole-map plan against tcod is ``run.py``'s section 1). Every figure is a
ratio of two things measured in one run, alternated. ``benchmarks/run.py`` writes them into
RESULTS.md; alone, ``.venv/bin/python benchmarks/scale.py`` prints the in-process figures.
"""

from __future__ import annotations

import gc
import statistics
import time
import tracemalloc
from collections.abc import Callable
from typing import Any

import httpx
import numpy as np
import orjson

import planner
from planner.analysis.cells import BLOCKED_CELL, FREE, TUNNEL

Grid = np.ndarray


def random_map(size: int, seed: int = 0) -> Grid:
    rng = np.random.default_rng(seed)
    grid = (rng.random((size, size)) < 0.2).astype(np.uint8)
    grid[:3, :3] = 0
    grid[-3:, -3:] = 0
    return grid


def alternate(fns: dict[str, Callable[[], object]], repeats: int) -> dict[str, float]:
    """Median seconds of each function, the functions interleaved, after one warm-up each."""
    for fn in fns.values():
        fn()
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return {name: statistics.median(v) for name, v in times.items()}


def near_cells(
    analysis: planner.Analysis, count: int, distance: int = 50
) -> list[tuple[tuple[int, int], ...]]:
    """(start, goal) pairs ``distance`` apart (the larger of the row and column offsets),
    in the map's middle, each goal reachable from its start (tried once, untimed)."""
    rng = np.random.default_rng(3)
    H = analysis.shape[0]
    pairs: list[tuple[tuple[int, int], ...]] = []
    while len(pairs) < count:
        r, c = (int(v) for v in rng.integers(H // 4, 3 * H // 4, size=2))
        off = int(rng.integers(0, distance + 1))
        gr, gc = r + distance * int(rng.choice([-1, 1])), c + off * int(rng.choice([-1, 1]))
        if analysis.state[r, c] != FREE or analysis.state[gr, gc] != FREE:
            continue
        try:
            planner.plan(None, (r, c), (gr, gc), analysis=analysis)
        except planner.NoValidPath:
            continue
        pairs.append(((r, c), (gr, gc)))
    return pairs


def bench_plans(size: int = 4096, near_repeats: int = 20, far_repeats: int = 3) -> dict[str, Any]:
    """Near (goal ~50 cells away) and corner-to-corner plans, the analysis cached; the memory
    each plan holds (traced numpy allocations while the plan is alive) per map cell."""
    grid = random_map(size)
    analysis = planner.analyse(grid)
    near = near_cells(analysis, near_repeats)
    far = ((1, 1), (size - 2, size - 2))

    def run(pair: tuple[tuple[int, int], ...]) -> tuple[float, planner.Plan]:
        t0 = time.perf_counter()
        p = planner.plan(None, pair[0], pair[1], analysis=analysis)
        _ = p.path, p.length  # the path the robot would follow, and its costs
        return time.perf_counter() - t0, p

    run(near[0])
    near_t: list[float] = []
    far_t: list[float] = []
    near_mem: list[float] = []
    far_mem: list[float] = []
    settled: list[float] = []
    reached = 0
    for i in range(max(near_repeats, far_repeats)):  # timed, near and far alternated
        if i < near_repeats:
            t, p = run(near[i])
            near_t.append(t)
            settled.append(p.wave.settled_cells if hasattr(p.wave, "settled_cells") else grid.size)
            reached += p.path[-1].tolist() == list(near[i][1])
            del p
        if i < far_repeats:
            t, p = run(far)
            far_t.append(t)
            del p
    for pair in [*near[:5], far]:  # memory, untimed: tracing slows every allocation
        gc.collect()
        tracemalloc.start()
        _, p = run(pair)
        held = tracemalloc.get_traced_memory()[0] / grid.size
        tracemalloc.stop()
        (far_mem if pair is far else near_mem).append(held)
        del p
    whole = planner.plan(None, far[0], far[1], analysis=analysis, whole=True)
    near_ms, far_ms = statistics.median(near_t) * 1e3, statistics.median(far_t) * 1e3
    return {
        "size": size,
        "near_ms": near_ms,
        "near_p90_ms": float(np.percentile(near_t, 90)) * 1e3,
        "far_ms": far_ms,
        "ratio": near_ms / far_ms,
        "near_bytes_per_cell": statistics.median(near_mem),
        "near_bytes_per_cell_max": max(near_mem),
        "far_bytes_per_cell": statistics.median(far_mem),
        "whole_wave_bytes_per_cell": whole.wave.nbytes / grid.size,
        "near_settled": statistics.median(settled),
        "near_plans": near_repeats,
        "near_reached": reached,
    }


def numpy_analysis(grid: Grid, weight: float = 0.5, radius: int = 2) -> tuple[Grid, int, Grid]:
    """The analysis as numpy and scipy.ndimage would write it: tunnels and gates from shifted
    views, clean from box filters (``uniform_filter`` with the outside counted as blocked)."""
    import scipy.ndimage as ndi

    b = np.pad(grid, 1, constant_values=1).astype(bool)
    free = ~b[1:-1, 1:-1]
    tunnel = free & ((b[:-2, 1:-1] & b[2:, 1:-1]) | (b[1:-1, :-2] & b[1:-1, 2:]))
    state = np.where(free, np.where(tunnel, TUNNEL, FREE), BLOCKED_CELL).astype(np.uint8)
    g = grid == 0
    gates = int(
        np.count_nonzero(g[:-1, :-1] & g[1:, 1:] & ~g[:-1, 1:] & ~g[1:, :-1])
        + np.count_nonzero(g[:-1, 1:] & g[1:, :-1] & ~g[:-1, :-1] & ~g[1:, 1:])
    )
    blocked = (state != FREE).astype(np.float32)  # sealed tunnels count as blocked
    clean = np.zeros(grid.shape, dtype=np.float32)
    inner = blocked
    for d in range(1, radius + 1):
        side = 2 * d + 1
        box = ndi.uniform_filter(blocked, size=side, mode="constant", cval=1.0) * side**2
        clean += (box - inner) / d
        inner = box
    clean *= weight
    clean[state == BLOCKED_CELL] = 0
    return state, gates, clean


def bench_analysis(size: int = 4096, repeats: int = 3) -> dict[str, float]:
    grid = random_map(size)
    ours = planner.analyse(grid)
    state, gates, clean = numpy_analysis(grid)
    assert np.array_equal(state, ours.state)
    assert gates == ours.gates
    assert np.allclose(clean, ours.clean, atol=1e-4)
    t = alternate(
        {"ours": lambda: planner.analyse(grid), "numpy": lambda: numpy_analysis(grid)}, repeats
    )
    return {
        "ours_ms": t["ours"] * 1e3,
        "numpy_ms": t["numpy"] * 1e3,
        "ratio": t["ours"] / t["numpy"],
    }


def bench_upload(
    ours_url: str, bare_url: str, size: int = 4096, repeats: int = 4
) -> dict[str, float]:
    """``POST /maps`` of a ``size``-square map as rows against a bare FastAPI echo of the same
    body (loopback, client-observed); in-process, ``parse_rows`` against the numpy one-liner."""
    grid = random_map(size, seed=5)
    rows = ["".join(".@"[v] for v in row) for row in grid.tolist()]
    body = orjson.dumps({"rows": rows})
    headers = {"content-type": "application/json"}
    with httpx.Client(timeout=600) as client:

        def ours() -> None:
            client.post(ours_url + "/maps", content=body, headers=headers).raise_for_status()

        def bare() -> None:
            client.post(bare_url + "/echo", content=body, headers=headers).raise_for_status()

        t = alternate({"ours": ours, "bare": bare}, repeats)
    lookup = np.full(256, 255, dtype=np.uint8)
    lookup[ord(".")] = 0
    lookup[ord("@")] = 1

    def numpy_parse() -> Grid:
        out: Grid = lookup[np.frombuffer("".join(rows).encode("ascii"), dtype=np.uint8)]
        return out.reshape(len(rows), -1)

    p = alternate({"ours": lambda: planner.parse_rows(rows), "numpy": numpy_parse}, 5)
    return {
        "mb": len(body) / 1e6,
        "ours_s": t["ours"],
        "bare_s": t["bare"],
        "ratio": t["ours"] / t["bare"],
        "parse_ms": p["ours"] * 1e3,
        "numpy_parse_ms": p["numpy"] * 1e3,
        "parse_ratio": p["ours"] / p["numpy"],
    }


def main() -> None:
    """The in-process figures (``run.py`` adds the upload, which needs the servers)."""
    planner.warm_up()
    print(bench_analysis())
    print(bench_plans())


if __name__ == "__main__":
    main()

"""Side-by-side benchmarks: the planner against tcod, scikit-image, pyastar2d and bare FastAPI.

Every figure that matters is a ratio of two things measured in the same run on the same machine,
alternating between them, so a noisy shared machine slows both alike. Run it with
``make bench``; it prints a table and writes ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import statistics
import time
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

import numpy as np

import planner

ROOT = Path(__file__).resolve().parents[1]
MOVINGAI = ROOT.parent / "shared" / "maps" / "movingai"
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
SQRT2 = 2**0.5


def timed(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def alternate(fns: dict[str, Callable[[], object]], repeats: int) -> dict[str, list[float]]:
    """Run each function ``repeats`` times, interleaved, after one untimed warm-up call each."""
    for fn in fns.values():
        fn()
    out: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            out[name].append(timed(fn))
    return out


def random_map(size: int, seed: int = 0) -> tuple[np.ndarray, tuple[int, int], tuple[int, int]]:
    """A map with 20% random obstacles, and two far-apart cells of its largest open region."""
    rng = np.random.default_rng(seed)
    grid = (rng.random((size, size)) < 0.2).astype(np.uint8)
    grid[:3, :3] = 0
    grid[-3:, -3:] = 0
    return grid, (1, 1), (size - 2, size - 2)


def bench_field(size: int, repeats: int) -> dict[str, float]:
    import skimage.graph
    import tcod

    grid, start, goal = random_map(size)
    tcod_cost = np.where(grid == 0, 1, 0).astype(np.int32)
    mcp_cost = np.where(grid == 0, 1.0, np.inf)

    def ours() -> None:
        planner.plan(grid, start, goal, preset="wide")

    def tcod_field() -> None:
        dist = np.full(grid.shape, np.iinfo(np.int32).max, dtype=np.int32)
        dist[goal] = 0
        tcod.path.dijkstra2d(dist, tcod_cost, 100, 141, out=dist)

    def skimage_field() -> None:
        skimage.graph.MCP_Geometric(mcp_cost).find_costs([goal])

    t = alternate({"ours": ours, "tcod": tcod_field, "skimage": skimage_field}, repeats)
    med = {k: statistics.median(v) for k, v in t.items()}
    return {
        "ours_ms": med["ours"] * 1e3,
        "tcod_ms": med["tcod"] * 1e3,
        "skimage_ms": med["skimage"] * 1e3,
        "ratio_tcod": med["ours"] / med["tcod"],
        "ratio_skimage": med["ours"] / med["skimage"],
    }


def octile(path: np.ndarray) -> float:
    steps = np.abs(np.diff(np.asarray(path), axis=0)).sum(axis=1)
    return float(np.count_nonzero(steps == 1) + SQRT2 * np.count_nonzero(steps == 2))


def bench_query(lines_per_map: int) -> list[dict[str, object]]:
    import pyastar2d
    import tcod

    rows: list[dict[str, object]] = []
    for scen in sorted(MOVINGAI.glob("*.scen")):
        lines = planner.read_scen(scen)
        grid = planner.read_map(MOVINGAI / Path(lines[0].map_name).name)
        if grid.shape != (512, 512):
            continue
        picks = np.linspace(0, len(lines) - 1, lines_per_map).round().astype(int)
        lines = [lines[i] for i in picks]
        analysis = planner.analyse(grid, seal_tunnels=False, clean_weight=0.0, clean_radius=1)
        tcod_cost = np.where(grid == 0, 1, 0).astype(np.int32)
        astar_w = np.where(grid == 0, 1.0, np.inf).astype(np.float32)
        times: dict[str, list[float]] = {"ours": [], "tcod": [], "pyastar2d": []}
        agree = {"ours": 0, "tcod": 0, "pyastar2d": 0}
        for line in lines:
            s, g = line.start, line.goal
            t0 = time.perf_counter()
            p = planner.plan(None, s, g, preset="shortest", analysis=analysis)
            times["ours"].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            tp = tcod.path.path2d(
                tcod_cost, start_points=[s], end_points=[g], cardinal=100, diagonal=141
            )
            times["tcod"].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            ap = pyastar2d.astar_path(astar_w, s, g, allow_diagonal=True)
            times["pyastar2d"].append(time.perf_counter() - t0)
            for name, length in (
                ("ours", p.length),
                ("tcod", octile(tp)),
                ("pyastar2d", octile(ap)),
            ):
                agree[name] += abs(length - line.optimal) <= 1e-3
        med = {k: statistics.median(v) for k, v in times.items()}
        rows.append(
            {
                "map": scen.name.removesuffix(".map.scen"),
                "queries": len(lines),
                **{f"{k}_ms": v * 1e3 for k, v in med.items()},
                "ratio_tcod": med["ours"] / med["tcod"],
                "ratio_pyastar2d": med["ours"] / med["pyastar2d"],
                **{f"{k}_agree": agree[k] / len(lines) for k in agree},
            }
        )
    return rows


def bench_step(steps: int) -> dict[str, float]:
    grid, start, goal = random_map(1024)
    p = planner.plan(grid, start, goal, preset="wide")
    episode_rng = np.random.default_rng(1)
    free = np.argwhere(grid == 0)
    times = []
    session = planner.Session(p)
    obstacles = free[episode_rng.choice(len(free), 10, replace=False)]
    for _ in range(steps):
        if session.state.status in ("arrived", "blocked"):
            session = planner.Session(p)
        t0 = time.perf_counter()
        session.step(obstacles)
        times.append(time.perf_counter() - t0)
    arr = np.asarray(times) * 1e6
    return {"median_us": float(np.median(arr)), "p99_us": float(np.percentile(arr, 99))}


def bench_memory() -> dict[str, float]:
    grid, start, goal = random_map(1024)
    p = planner.plan(grid, start, goal, preset="wide")
    _ = p.min_clearance  # the distance transform, kept by the analysis once computed
    cells = grid.size
    return {
        "analysis_bytes_per_cell": p.analysis.nbytes / cells,
        "wave_bytes_per_cell": p.wave.nbytes / cells,
    }


def versions() -> dict[str, str]:
    names = ["numpy", "numba", "edt", "tcod", "scikit-image", "pyastar2d", "fastapi", "uvicorn"]
    out = {}
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "-"
    return out


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--queries", type=int, default=60, help="scenario lines per 512 x 512 map")
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md")
    args = parser.parse_args()
    planner.warm_up()

    lines: list[str] = []

    def out(text: str = "") -> None:
        print(text, flush=True)
        lines.append(text)

    out("# Benchmark results")
    out()
    out(f"- Date: {dt.datetime.now(dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}")
    out(f"- Machine: {machine()}")
    out("- Versions: " + ", ".join(f"{k} {v}" for k, v in versions().items()))
    out("- Command: `make bench` (each comparison alternates its contenders in one run)")
    out()
    out("## 1. Field: a whole `wide` plan against one cost-to-go field")
    out()
    out(
        "20% random obstacles. Ours: `planner.plan(preset='wide')`, cold: analysis (gates, tunnels,"
    )
    out("clean), both waves `k` and `kw`, and the path. tcod: `dijkstra2d` (costs 100/141);")
    out("scikit-image: `MCP_Geometric.find_costs`. Medians of alternated runs.")
    out()
    out("| map | ours (ms) | tcod (ms) | skimage (ms) | ours / tcod | ours / skimage |")
    out("|---|---|---|---|---|---|")
    for size in (256, 1024):
        f = bench_field(size, args.repeats)
        out(
            f"| {size} x {size} | {f['ours_ms']:.1f} | {f['tcod_ms']:.1f} | {f['skimage_ms']:.1f} "
            f"| **{f['ratio_tcod']:.2f}** | {f['ratio_skimage']:.2f} |"
        )
    out()
    out("## 2. Query: `shortest` against A* on the 512 x 512 Moving AI maps")
    out()
    out("Ours plans with the map's cached analysis (a whole wave per query); tcod `path2d` and")
    out("pyastar2d run A*. 'agree': share of queries whose path length is the benchmark's")
    out("optimum within 1e-3 (tcod and pyastar2d cut corners, which Moving AI forbids).")
    out()
    out(
        "| map | queries | ours (ms) | tcod (ms) | pyastar2d (ms) | ours / tcod "
        "| ours / pyastar2d | agree ours / tcod / pyastar2d |"
    )
    out("|---|---|---|---|---|---|---|---|")
    for r in bench_query(args.queries):
        out(
            f"| {r['map']} | {r['queries']} | {r['ours_ms']:.2f} | {r['tcod_ms']:.2f} "
            f"| {r['pyastar2d_ms']:.2f} | {r['ratio_tcod']:.2f} | {r['ratio_pyastar2d']:.2f} "
            f"| {r['ours_agree']:.0%} / {r['tcod_agree']:.0%} / {r['pyastar2d_agree']:.0%} |"
        )
    out()
    out("## 3. Step")
    out()
    s = bench_step(args.steps)
    out(f"In-process `Session.step` on a 1024 x 1024 map with 10 dynamic obstacles, {args.steps}")
    out(f"steps: median **{s['median_us']:.1f} us**, p99 {s['p99_us']:.1f} us.")
    out()
    out("## 4. Memory")
    out()
    m = bench_memory()
    out("A cached analysis of a 1024 x 1024 map (states, clean, distance transform) holds")
    out(f"**{m['analysis_bytes_per_cell']:.1f} bytes per cell**; a goal wave (k, kw, the grid it")
    out(f"ran over) {m['wave_bytes_per_cell']:.1f} bytes per cell.")
    out()
    if not args.no_write:
        RESULTS.write_text("\n".join(lines) + "\n")
        print(f"\nwrote {RESULTS.relative_to(ROOT)}")


if __name__ == "__main__":
    main()

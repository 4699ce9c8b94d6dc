"""Side-by-side benchmarks: the planner against tcod, scikit-image, pyastar2d and bare FastAPI.

Every figure that matters is a ratio of two things measured in the same run on the same machine,
alternating between them, so a noisy shared machine slows both alike. Run it with
``make bench`` (``make bench BENCH_ARGS=--quick`` for fewer repeats); it prints every section and
writes ``benchmarks/RESULTS.md``: the machine (``lscpu``'s CPU), the versions, then one table of
issue 14's targets from this run (``benchmarks/summary.py``: ratio, absolute figures, threshold,
met or not), then the sections. The HTTP section is ``benchmarks/http_steps.py``'s (``wrk``
against the real service on the memory store and on Redis, and a bare FastAPI echo).
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import re
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from importlib import metadata
from pathlib import Path
from typing import Any

import http_steps
import httpx
import numpy as np
import scale
import summary
from common import Process, free_port

import planner

ROOT = Path(__file__).resolve().parents[1]
# Beside the repository; from a git worktree (``wt/<name>``), one level further up.
MOVINGAI = next(
    (p for p in (ROOT.parent / "shared", ROOT.parents[1] / "shared") if p.is_dir()),
    ROOT.parent / "shared",
) / "maps" / "movingai"  # fmt: skip
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
KEPT = "<!-- nav2-baseline -->"
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

    def ours() -> object:
        # The whole-map wave (both fields), not the resumable search: the field against field.
        return planner.plan(grid, start, goal, preset="wide", whole=True).path

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
    p = planner.plan(grid, start, goal, preset="wide", whole=True)
    _ = p.min_clearance  # the distance transform, kept by the analysis once computed
    cells = grid.size
    return {
        "analysis_bytes_per_cell": p.analysis.nbytes / cells,
        "wave_bytes_per_cell": p.wave.nbytes / cells,
    }


class Server:
    """``uvicorn APP`` in a child process on a free 127.0.0.1 port, stopped on exit."""

    def __init__(self, app: str, env: dict[str, str] | None = None) -> None:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = int(s.getsockname()[1])
        self.url = f"http://127.0.0.1:{self.port}"
        self.started = time.perf_counter()
        self.process = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", app, "--host", "127.0.0.1", "--port",
             str(self.port), "--log-level", "warning"],
            cwd=ROOT, env={**os.environ, **(env or {})},
        )  # fmt: skip

    def wait(self, path: str = "/docs", timeout: float = 300) -> None:
        deadline = time.monotonic() + timeout
        while True:
            try:
                httpx.get(self.url + path, timeout=5).raise_for_status()
                return
            except httpx.TransportError:
                if self.process.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"{self.url} did not start") from None
                time.sleep(0.02)

    def __enter__(self) -> Server:
        return self

    def __exit__(self, *exc: object) -> None:
        self.process.terminate()
        self.process.wait(timeout=30)


def bench_http_steps(seconds: int, repeats: int) -> tuple[list[dict[str, Any]], list[str]]:
    """``benchmarks/http_steps.py``'s cases (memory store, then a private ``redis-server``),
    each against the bare echo with the same bodies and connections; and what went wrong, if
    anything (a store that could not be measured is left out, and its targets are not met)."""
    results: list[dict[str, Any]] = []
    problems: list[str] = []
    if shutil.which("wrk") is None:
        return results, ["`wrk` is not installed (Debian: `apt-get install -y wrk`)"]
    with tempfile.TemporaryDirectory() as name, http_steps.echo() as bare:
        tmp = Path(name)
        bare.wait("/docs")
        try:
            results += http_steps.run_store("memory", {}, bare, seconds, repeats, tmp)
        except (subprocess.CalledProcessError, httpx.HTTPError, RuntimeError, KeyError) as e:
            problems.append(f"memory store: {e!r}")
        redis = shutil.which("redis-server")
        if redis is None:
            problems.append("`redis-server` is not installed: the Redis store was not measured")
            return results, problems
        port = free_port()
        argv = [redis, "--port", str(port), "--bind", "127.0.0.1", "--save", ""]
        argv += ["--appendonly", "no"]
        with Process(argv, port):
            time.sleep(0.5)
            env = {"PLANNER_STORE_URL": f"redis://127.0.0.1:{port}/0"}
            try:
                results += http_steps.run_store("redis", env, bare, seconds, repeats, tmp)
            except (subprocess.CalledProcessError, httpx.HTTPError, RuntimeError, KeyError) as e:
                problems.append(f"Redis store: {e!r}")
    return results, problems


def bench_upload(repeats: int) -> dict[str, float]:
    """Time for the service to accept a 1024 x 1024 map as rows (loopback, client-observed)."""
    grid, _, _ = random_map(1024)
    times = []
    with Server("service.main:app") as ours:
        ours.wait("/healthz")
        with httpx.Client(base_url=ours.url, timeout=120) as client:
            for i in range(repeats):
                grid[0, 0] = i % 2  # a new map every other time: both the 201 and the 200 path
                rows = ["".join(".@"[v] for v in row) for row in grid.tolist()]
                t0 = time.perf_counter()
                client.post("/maps", json={"rows": rows}).raise_for_status()
                times.append(time.perf_counter() - t0)
    return {"median_s": statistics.median(times), "max_s": max(times)}


def bench_cold_start(cold: bool = True) -> dict[str, float]:
    """Seconds from starting the service process to the first plan served, numba cache warm
    (the project's cache, filled by earlier runs) and, if ``cold``, cold (an empty cache
    directory)."""
    body = {"rows": ["......", ".@@@@.", "......"], "start": [0, 0], "goal": [2, 5]}
    out = {}
    with tempfile.TemporaryDirectory() as empty:
        cases = [("warm", {}), ("cold", {"NUMBA_CACHE_DIR": empty})][: 2 if cold else 1]
        for name, env in cases:
            with Server("service.main:app", env) as server:
                deadline = time.monotonic() + 600
                while True:
                    try:
                        r = httpx.post(server.url + "/maps", json=body, timeout=600)
                        r.raise_for_status()
                        break
                    except httpx.TransportError:
                        assert time.monotonic() < deadline, "the service did not start"
                        time.sleep(0.01)
                out[name] = time.perf_counter() - server.started
    return out


def scale_section(
    out: Callable[..., None], field: dict[str, float], far_repeats: int
) -> dict[str, dict[str, Any]]:
    """Section 6: issue 14's figures at 4096 x 4096, each a ratio measured side by side in this
    run (the whole-map plan against tcod is section 1's 1024 x 1024 row, ``field``)."""
    plans = scale.bench_plans(far_repeats=far_repeats)
    analysis = scale.bench_analysis()
    with Server("service.main:app") as ours, Server("benchmarks.bare_app:app") as bare:
        ours.wait("/healthz")
        bare.wait()
        upload = scale.bench_upload(ours.url, bare.url)
    n = plans["size"]
    out("## 6. Scale: a 4096 x 4096 map")
    out()
    out(f"A {n} x {n} map with 20% random obstacles, its analysis cached. A near plan: start and")
    out(
        f"goal 50 cells apart (octile), {plans['near_plans']} pairs in the map's middle; a far plan:"
    )
    out("corner to corner. A plan: `planner.plan(None, start, goal, analysis=...)` and its path.")
    out("Memory: numpy allocations held by the plan (tracemalloc), per cell of the map. The whole-")
    out("map plan and its tcod field are section 1's 1024 x 1024 row.")
    out("Analysis: `planner.analyse` against the same states, gate count and clean field written")
    out("with numpy and `scipy.ndimage.uniform_filter`. Upload: `POST /maps` with the map as")
    out("`rows` against a bare FastAPI endpoint echoing the same body (loopback, one worker).")
    out()
    out("| measure | ours | against | ratio (target) |")
    out("|---|---|---|---|")
    out(
        f"| near plan, cached analysis | {plans['near_ms']:.2f} ms (p90 {plans['near_p90_ms']:.2f}) "
        f"| far plan: {plans['far_ms']:.0f} ms | **{plans['ratio']:.4f}** (<= 0.01; <= 5 ms) |"
    )
    out(
        f"| memory held by a near plan | {plans['near_bytes_per_cell']:.3f} B/cell "
        f"(worst {plans['near_bytes_per_cell_max']:.3f}) "
        f"| a whole-map wave: {plans['whole_wave_bytes_per_cell']:.1f} B/cell "
        f"| **{plans['near_bytes_per_cell_max'] / 17:.4f}** of 17, worst (<= 0.01) |"
    )
    out(f"| memory held by a far plan | {plans['far_bytes_per_cell']:.1f} B/cell | | |")
    out(
        f"| whole-map `wide` plan, 1024 x 1024 | {field['ours_ms']:.1f} ms "
        f"| tcod `dijkstra2d`: {field['tcod_ms']:.1f} ms | **{field['ratio_tcod']:.2f}** (<= 0.5) |"
    )
    out(
        f"| analysis | {analysis['ours_ms']:.0f} ms | numpy + scipy: {analysis['numpy_ms']:.0f} ms "
        f"| **{analysis['ratio']:.2f}** (<= 1) |"
    )
    out(
        f"| `POST /maps`, {upload['mb']:.0f} MB of rows | {upload['ours_s']:.2f} s "
        f"| bare echo: {upload['bare_s']:.2f} s | **{upload['ratio']:.2f}** |"
    )
    out(
        f"| parsing the rows (`parse_rows`) | {upload['parse_ms']:.0f} ms "
        f"| numpy lookup: {upload['numpy_parse_ms']:.0f} ms | **{upload['parse_ratio']:.2f}** (<= 1) |"
    )
    out()
    out(
        f"A near plan settles a median {plans['near_settled']:.0f} cells of the {n * n}; "
        f"{plans['near_reached']} of {plans['near_plans']} reached their goal."
    )
    out()
    return {"plans": plans, "analysis": analysis, "upload": upload}


def http_section(out: Callable[..., None], seconds: int, repeats: int) -> list[dict[str, Any]]:
    """Section 3's HTTP part: ``benchmarks/http_steps.py``'s cases and table, from this run."""
    results, problems = bench_http_steps(seconds, repeats)
    out("Over HTTP, driven by `wrk` (`benchmarks/http_steps.py`, `benchmarks/http_steps.lua`): the")
    out("real service (`python -m service`, default settings and logging) on the memory store and")
    out("on a private `redis-server`, and a bare FastAPI JSON echo (`benchmarks/bare_app.py`)")
    out("beside it. One 1024 x 1024 map (10% random obstacles and walls that make the way to the")
    out("goal ~32,000 cells long, so no robot arrives during a run); each case gets fresh plans,")
    out(
        f"then `wrk` runs {seconds} s with one thread a connection and 10 random dynamic obstacles a"
    )
    out("step, the echo with the same bodies and connections just before it; each side's best")
    out(f"of {repeats} such runs (requests/s). 'c=16, one plan'")
    out("steps one plan from 16 connections without `seq` (its steps are serialised by the plan's")
    out("lock). CPU µs: the server process's user + system time over the run per request served;")
    out("a core: the requests one core serves at that cost (10^6 / CPU µs).")
    out("non-2xx counts non-2xx answers and socket errors: a run with any is not a result.")
    out()
    if results:
        for line in http_steps.table(results).splitlines():
            out(line)
        out()
        echo_errors = sum(r["bare"]["errors"] for r in results)
        out(f"The echo's runs had {echo_errors:.0f} non-2xx answers or socket errors in all (the")
        out("summary counts both sides of a ratio: an error on either spoils it).")
        out()
    for problem in problems:
        out(f"Not measured: {problem}.")
        out()
    out("The Python (httpx) load generator this section used before is gone: sharing the 2 cores")
    out("with the server, it saturated first, and `wrk` measures everything it did (requests/s,")
    out("p50 / p99, each connection stepping its own plan with `seq`), so nothing needs it.")
    out()
    return results


def versions() -> dict[str, str]:
    names = [
        "numpy", "numba", "edt", "scipy", "tcod", "scikit-image", "pyastar2d", "fastapi",
        "uvicorn", "orjson", "redis",
    ]  # fmt: skip
    out = {}
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "-"
    return out


def tool_version(argv: list[str]) -> str:
    try:
        done = subprocess.run(argv, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return "-"
    found = re.search(r"\d+\.\d+(?:\.\d+)?", done.stdout or done.stderr)
    return found.group() if found else "-"


def machine() -> str:
    """The CPU as ``lscpu`` names it and its count, the Python and the operating system."""
    return (
        f"{http_steps.cpu_model()}, {platform.system()} {platform.release()}, "
        f"Python {platform.python_version()}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer repeats: a faster, rougher run")
    parser.add_argument("--repeats", type=int, default=None, help="alternated runs (7; quick 3)")
    parser.add_argument("--queries", type=int, default=None, help="lines per 512² map (60; 20)")
    parser.add_argument("--steps", type=int, default=None, help="in-process steps (20000; 5000)")
    parser.add_argument("--wrk-seconds", type=int, default=None, help="a wrk run's length (3)")
    parser.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md")
    args = parser.parse_args()
    quick = args.quick
    repeats = args.repeats or (3 if quick else 7)
    queries = args.queries or (20 if quick else 60)
    steps = args.steps or (5000 if quick else 20000)
    wrk_seconds = args.wrk_seconds or 3
    began = time.monotonic()
    load_before = os.getloadavg()
    planner.warm_up()

    lines: list[str] = []
    measured: dict[str, Any] = {}

    def out(text: str = "") -> None:
        print(text, flush=True)
        lines.append(text)

    out("## 1. Field: a whole `wide` plan against one cost-to-go field")
    out()
    out(
        "20% random obstacles. Ours: `planner.plan(preset='wide', whole=True)`, cold: analysis (gates,"
    )
    out("tunnels, clean), both whole-map waves `k` and `kw` (two threads), and the path. tcod:")
    out("`dijkstra2d` (costs 100/141), one thread;")
    out(f"scikit-image: `MCP_Geometric.find_costs`. Medians of {repeats} alternated runs.")
    out()
    out("| map | ours (ms) | tcod (ms) | skimage (ms) | ours / tcod | ours / skimage |")
    out("|---|---|---|---|---|---|")
    for size in (256, 1024):
        f = bench_field(size, repeats)
        out(
            f"| {size} x {size} | {f['ours_ms']:.1f} | {f['tcod_ms']:.1f} | {f['skimage_ms']:.1f} "
            f"| **{f['ratio_tcod']:.2f}** | {f['ratio_skimage']:.2f} |"
        )
        if size == 1024:
            measured["field"] = f
    out()
    out("## 2. Query: `shortest` against A* on the 512 x 512 Moving AI maps")
    out()
    out("Ours plans with the map's cached analysis (a resumable search per query, handing over to")
    out("the whole-map wave past 1/64 of the map); tcod `path2d` and")
    out("pyastar2d run A*. 'agree': share of queries whose path length is the benchmark's")
    out("optimum within 1e-3 (tcod and pyastar2d cut corners, which Moving AI forbids).")
    out()
    out(
        "| map | queries | ours (ms) | tcod (ms) | pyastar2d (ms) | ours / tcod "
        "| ours / pyastar2d | agree ours / tcod / pyastar2d |"
    )
    out("|---|---|---|---|---|---|---|---|")
    for r in bench_query(queries):
        out(
            f"| {r['map']} | {r['queries']} | {r['ours_ms']:.2f} | {r['tcod_ms']:.2f} "
            f"| {r['pyastar2d_ms']:.2f} | {r['ratio_tcod']:.2f} | {r['ratio_pyastar2d']:.2f} "
            f"| {r['ours_agree']:.0%} / {r['tcod_agree']:.0%} / {r['pyastar2d_agree']:.0%} |"
        )
    out()
    out("## 3. Step")
    out()
    s = bench_step(steps)
    out(f"In-process `Session.step` on a 1024 x 1024 map with 10 dynamic obstacles, {steps}")
    out(f"steps: median **{s['median_us']:.1f} us**, p99 {s['p99_us']:.1f} us.")
    out()
    # Each HTTP side's best of 5 short runs, alternated: on a shared machine, more chances for
    # both to meet a quiet moment than 3 longer runs give in the same time.
    measured["http"] = http_section(out, wrk_seconds, 1 if quick else 5)
    out("## 4. Memory")
    out()
    m = bench_memory()
    out("A cached analysis of a 1024 x 1024 map (states, clean, distance transform) holds")
    out(f"**{m['analysis_bytes_per_cell']:.1f} bytes per cell**; a goal wave (k, kw, the grid it")
    out(f"ran over) {m['wave_bytes_per_cell']:.1f} bytes per cell.")
    out()
    out("## 5. Upload and cold start")
    out()
    u = bench_upload(6)
    out(f"`POST /maps` with a 1024 x 1024 map as `rows`: median **{u['median_s']:.3f} s**, worst")
    out(f"{u['max_s']:.3f} s (loopback, client-observed, parsing and hashing included).")
    out()
    c = bench_cold_start(cold=not quick)
    out(f"From starting the service process to the first plan served: **{c['warm']:.2f} s** with")
    if "cold" in c:
        out(f"numba's cache warm, {c['cold']:.2f} s cold (every kernel compiled at start-up).")
    else:
        out("numba's cache warm (`--quick`: the cold start, every kernel compiled, not measured).")
    out()
    measured.update(scale_section(out, measured["field"], far_repeats=2 if quick else 3))

    took = time.monotonic() - began
    header = [
        "# Benchmark results",
        "",
        f"- Date: {dt.datetime.now(dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}",
        f"- Machine: {machine()}; load average {load_before[0]:.1f} at the start, "
        f"{os.getloadavg()[0]:.1f} at the end (the machine is shared: absolute times are noisy, "
        "the ratios are each measured side by side)",
        "- Versions: "
        + ", ".join(f"{k} {v}" for k, v in versions().items())
        + f", wrk {tool_version(['wrk', '-v'])}, "
        + f"redis-server {tool_version(['redis-server', '--version'])}",
        f"- Command: `make bench`{' (`--quick`)' if quick else ''}, that is "
        f"`benchmarks/run.py{' --quick' if quick else ''}`; the whole run took "
        f"{took / 60:.1f} min. Each comparison alternates its contenders in this one run.",
        "",
        "## Issue 14's targets (the HTTP ones as issue 21 set them), from this run",
        "",
        "Each target as measured in this run, the ratio (or value) compared with its threshold and",
        "the absolute figures it comes from; the sections below give the details. An HTTP figure",
        "from a `wrk` run with any non-2xx answer or socket error is not a result, so not met.",
        "",
        *summary.table(summary.rows(measured)),
        "",
    ]
    print("\n".join(header), flush=True)
    print(f"run.py took {took:.0f} s", flush=True)
    if not args.no_write:
        # Sections other scripts write (benchmarks/nav2_baseline.py) are kept as they are.
        old = RESULTS.read_text() if RESULTS.exists() else ""
        kept = old[old.index(KEPT) :] if KEPT in old else ""
        RESULTS.write_text("\n".join(header + lines) + "\n" + ("\n" + kept if kept else ""))
        print(f"\nwrote {RESULTS.relative_to(ROOT)}")


if __name__ == "__main__":
    main()

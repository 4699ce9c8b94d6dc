"""Side-by-side benchmarks: the planner against tcod, scikit-image, pyastar2d and bare FastAPI.

Every figure that matters is a ratio of two things measured in the same run on the same machine,
alternating between them, so a noisy shared machine slows both alike. Run it with
``make bench``; it prints a table and writes ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import asyncio
import datetime as dt
import os
import platform
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

import httpx
import numpy as np
import scale

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


async def load(
    url: str, requests: list[list[tuple[str, dict[str, Any]]]]
) -> tuple[float, list[float]]:
    """Send each client's requests in order, the clients at once; (requests/s, latencies)."""
    latencies: list[float] = []
    limits = httpx.Limits(max_connections=len(requests))
    async with httpx.AsyncClient(base_url=url, limits=limits, timeout=60) as client:

        async def client_loop(queue: list[tuple[str, dict[str, Any]]]) -> None:
            for path, body in queue:
                t0 = time.perf_counter()
                r = await client.post(path, json=body)
                latencies.append(time.perf_counter() - t0)
                r.raise_for_status()

        t0 = time.perf_counter()
        await asyncio.gather(*(client_loop(q) for q in requests))
        elapsed = time.perf_counter() - t0
    return sum(map(len, requests)) / elapsed, latencies


def bench_http(steps: int) -> list[dict[str, float]]:
    """Step throughput and latency over HTTP against a bare endpoint echoing a body as large."""
    grid, start, goal = random_map(1024)
    rows = ["".join(".@"[v] for v in row) for row in grid.tolist()]
    rng = np.random.default_rng(2)
    out = []
    with Server("service.main:app") as ours, Server("benchmarks.bare_app:app") as bare:
        ours.wait("/healthz")
        bare.wait()
        map_id = httpx.post(ours.url + "/maps", json={"rows": rows}, timeout=120).json()["map_id"]
        for clients in (1, 16):
            plans = [
                httpx.post(
                    ours.url + "/plan",
                    json={"map_id": map_id, "start": list(start), "goal": list(goal)},
                    timeout=120,
                ).json()["plan_id"]
                for _ in range(clients)
            ]
            per_client = max(steps // clients, 50)
            step_queues = []
            for plan_id in plans:
                queue = []
                for seq in range(per_client):
                    cells = rng.integers(0, 1024, size=(10, 2)).tolist()
                    queue.append(
                        (f"/plan/{plan_id}/step", {"seq": seq, "dynamic_obstacles": cells})
                    )
                step_queues.append(queue)
            # The same bodies to the echo endpoint: the same bytes in, as many requests.
            echo_queues = [[("/echo", body) for _, body in q] for q in step_queues]
            best: dict[str, tuple[float, list[float]]] = {}
            for _ in range(2):  # alternate, keep each one's better run
                for name, url, queues in (
                    ("ours", ours.url, step_queues),
                    ("bare", bare.url, echo_queues),
                ):
                    if name == "ours":  # a fresh copy of the plans each round: seq restarts
                        queues = _fresh(ours.url, map_id, start, goal, queues)
                    rate, lat = asyncio.run(load(url, queues))
                    if name not in best or rate > best[name][0]:
                        best[name] = (rate, lat)
            row: dict[str, float] = {"clients": clients}
            for name, (rate, lat) in best.items():
                arr = np.asarray(lat) * 1e3
                row[f"{name}_rps"] = rate
                row[f"{name}_p50_ms"] = float(np.percentile(arr, 50))
                row[f"{name}_p99_ms"] = float(np.percentile(arr, 99))
            row["ratio"] = row["ours_rps"] / row["bare_rps"]
            out.append(row)
    return out


def _fresh(
    url: str,
    map_id: str,
    start: tuple[int, int],
    goal: tuple[int, int],
    queues: list[list[tuple[str, dict[str, Any]]]],
) -> list[list[tuple[str, dict[str, Any]]]]:
    """The same step bodies, addressed to new plans (each starts at seq 0 again)."""
    fresh = []
    for queue in queues:
        plan_id = httpx.post(
            url + "/plan", json={"map_id": map_id, "start": list(start), "goal": list(goal)}
        ).json()["plan_id"]
        fresh.append([(f"/plan/{plan_id}/step", body) for _, body in queue])
    return fresh


WRK_SCRIPT = ROOT / "benchmarks" / "http_steps.lua"


def wrk(url: str, connections: int, seconds: int, *args: str) -> dict[str, float]:
    """One ``wrk`` run of ``http_steps.lua``: requests/s, p50 and p99 (ms), errors (non-2xx
    responses and socket errors)."""
    out = subprocess.run(
        ["wrk", "-t", str(connections), "-c", str(connections), "-d", f"{seconds}s",
         "--latency", "-s", str(WRK_SCRIPT), url, "--", *args],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    scale_of = {"us": 1e-3, "ms": 1.0, "s": 1e3}
    result = {"errors": 0.0}
    for line in out.splitlines():
        words = line.split()
        if line.startswith("Requests/sec:"):
            result["rps"] = float(words[1])
        elif words[:1] in (["50%"], ["99%"]):
            value = words[1]
            unit = value.lstrip("0123456789.")
            result[f"p{words[0][:-1]}_ms"] = float(value[: -len(unit)]) * scale_of[unit]
        elif line.strip().startswith("Non-2xx or 3xx responses:"):
            result["errors"] += float(words[-1])
        elif line.strip().startswith("Socket errors:"):
            result["errors"] += sum(float(w.rstrip(",")) for w in words[3::2])
    return result


def bench_wrk(seconds: int = 5) -> list[dict[str, float]]:
    """Steps over HTTP driven by ``wrk`` (C, not the Python client): the memory store, one plan
    per connection, against a bare FastAPI echo of the same bodies; alternated, best of two."""
    grid, start, goal = random_map(1024)
    rows = ["".join(".@"[v] for v in row) for row in grid.tolist()]
    out = []
    with (
        Server("service.main:app") as ours,
        Server("benchmarks.bare_app:app") as bare,
        tempfile.TemporaryDirectory() as tmp,
    ):
        ours.wait("/healthz")
        bare.wait()
        map_id = httpx.post(ours.url + "/maps", json={"rows": rows}, timeout=120).json()["map_id"]
        ids = Path(tmp) / "plans"
        body = {"map_id": map_id, "start": list(start), "goal": list(goal)}
        for clients in (1, 16):
            best: dict[str, dict[str, float]] = {}
            for _ in range(2):
                plans = [
                    httpx.post(ours.url + "/plan", json=body, timeout=120).json()["plan_id"]
                    for _ in range(clients)
                ]  # fresh plans each run: seq starts at 0
                ids.write_text("\n".join(plans) + "\n")
                runs = {
                    "ours": wrk(ours.url, clients, seconds, str(ids)),
                    "bare": wrk(bare.url, clients, seconds, str(ids), "echo"),
                }
                for name, run in runs.items():
                    if name not in best or run["rps"] > best[name]["rps"]:
                        best[name] = run
            row = {"clients": float(clients), "ratio": best["ours"]["rps"] / best["bare"]["rps"]}
            for name, run in best.items():
                row.update({f"{name}_{k}": v for k, v in run.items()})
            out.append(row)
    return out


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


def bench_cold_start() -> dict[str, float]:
    """Seconds from starting the service process to the first plan served, numba cache warm
    (the project's cache, filled by earlier runs) and cold (an empty cache directory)."""
    body = {"rows": ["......", ".@@@@.", "......"], "start": [0, 0], "goal": [2, 5]}
    out = {}
    with tempfile.TemporaryDirectory() as empty:
        for name, env in (("warm", {}), ("cold", {"NUMBA_CACHE_DIR": empty})):
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


def scale_section(out: Callable[..., None], repeats: int) -> None:
    """Section 6: issue 14's figures, each a ratio measured side by side in this run."""
    plans = scale.bench_plans()
    analysis = scale.bench_analysis()
    field = bench_field(1024, repeats)
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
    out("map plan and its tcod field are section 1's 1024 x 1024 figures, measured again here.")
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
        f"| **{plans['near_bytes_per_cell'] / 17:.4f}** of 17 (<= 0.01) |"
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
    parser.add_argument("--http-steps", type=int, default=2000, help="steps per HTTP load run")
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
        "20% random obstacles. Ours: `planner.plan(preset='wide', whole=True)`, cold: analysis (gates,"
    )
    out("tunnels, clean), both whole-map waves `k` and `kw` (two threads), and the path. tcod:")
    out("`dijkstra2d` (costs 100/141), one thread;")
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
    out("Over HTTP (uvicorn on 127.0.0.1, one worker, the in-memory store; httpx clients in one")
    out("process): `POST /plan/{id}/step` with 10 obstacles on a 1024 x 1024 map, against a bare")
    out("FastAPI endpoint echoing the same bodies, alternated; each client steps its own plan.")
    out()
    out(
        "| clients | ours (req/s) | bare (req/s) | ours / bare | ours p50 / p99 (ms) | bare p50 / p99 (ms) |"
    )
    out("|---|---|---|---|---|---|")
    for h in bench_http(args.http_steps):
        out(
            f"| {h['clients']:.0f} | {h['ours_rps']:.0f} | {h['bare_rps']:.0f} | **{h['ratio']:.2f}** "
            f"| {h['ours_p50_ms']:.2f} / {h['ours_p99_ms']:.2f} "
            f"| {h['bare_p50_ms']:.2f} / {h['bare_p99_ms']:.2f} |"
        )
    out()
    out(
        "At 16 clients the load generator (one Python process, sharing the 2 cores with the server)"
    )
    out(
        "saturates first, so both columns there are mostly the client's; 1 client is the sharper test."
    )
    out()
    out(
        "The same measured with `wrk` (`benchmarks/http_steps.lua`, one connection per thread, each"
    )
    out("stepping its own plan; 5 s runs, best of two, alternated with the echo). A run with")
    out("errors is not a result: the errors column must read 0.")
    out()
    out(
        "| connections | ours (req/s) | bare (req/s) | ours / bare | ours p50 / p99 (ms) "
        "| bare p50 / p99 (ms) | errors ours / bare |"
    )
    out("|---|---|---|---|---|---|---|")
    for h in bench_wrk():
        out(
            f"| {h['clients']:.0f} | {h['ours_rps']:.0f} | {h['bare_rps']:.0f} | **{h['ratio']:.2f}** "
            f"| {h['ours_p50_ms']:.2f} / {h['ours_p99_ms']:.2f} "
            f"| {h['bare_p50_ms']:.2f} / {h['bare_p99_ms']:.2f} "
            f"| {h['ours_errors']:.0f} / {h['bare_errors']:.0f} |"
        )
    out()
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
    c = bench_cold_start()
    out(f"From starting the service process to the first plan served: **{c['warm']:.2f} s** with")
    out(f"numba's cache warm, {c['cold']:.2f} s cold (every kernel compiled at start-up).")
    out()
    scale_section(out, args.repeats)
    if not args.no_write:
        # Sections other scripts write (benchmarks/nav2_baseline.py) are kept as they are.
        old = RESULTS.read_text() if RESULTS.exists() else ""
        kept = old[old.index(KEPT) :] if KEPT in old else ""
        RESULTS.write_text("\n".join(lines) + "\n" + ("\n" + kept if kept else ""))
        print(f"\nwrote {RESULTS.relative_to(ROOT)}")


if __name__ == "__main__":
    main()

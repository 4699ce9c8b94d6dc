"""The service at scale (issue 14), in-process over ASGI: ``POST /plan`` with a goal ~50 cells
away against corner to corner on a 4096 x 4096 map with 20 % random obstacles (the analysis
cached first), the memory 20 near plans with different goals keep (RSS and the cache's bytes),
and the in-process step along a near plan.

Run it on two checkouts to compare them (figures from one machine, one after the other)::

    PYTHONPATH=. .venv/bin/python benchmarks/service_scale.py --label after
    PYTHONPATH=/path/to/main .venv/bin/python benchmarks/service_scale.py --label before
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import json
import statistics
import subprocess
import time
from typing import Any

import httpx
import numpy as np
import scale

import planner
from schemas import StepCreate
from service.config import Settings
from service.main import create_app
from service.resources import plans

SIZE = 4096
GIB = 1 << 30


def rss_bytes() -> int:
    """The process's resident set size now."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


def cpu_model() -> str:
    out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    for line in out.splitlines():
        if line.startswith("Model name:"):
            return line.split(":", 1)[1].strip()
    return "unknown"


async def run(near_plans: int, far_plans: int, timed_pairs: int) -> dict[str, Any]:
    settings = Settings(pool_size=2, cache_bytes=4 * GIB, max_body_bytes=64 << 20)
    app = create_app(settings)
    grid = scale.random_map(SIZE)
    analysis = planner.analyse(grid)
    pairs = scale.near_cells(analysis, 1 + near_plans + timed_pairs)
    del analysis
    rows = ["".join(".@"[v] for v in row) for row in grid.tolist()]
    async with app.router.lifespan_context(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(
            transport=transport, base_url="http://service", timeout=600
        ) as client:
            r = await client.post("/maps", json={"rows": rows})
            r.raise_for_status()
            map_id = r.json()["map_id"]
            del rows

            async def plan(start: Any, goal: Any) -> tuple[float, str]:
                body = {"map_id": map_id, "start": list(start), "goal": list(goal)}
                t0 = time.perf_counter()
                r = await client.post("/plan", json=body)
                elapsed = time.perf_counter() - t0
                r.raise_for_status()
                return elapsed, str(r.json()["plan_id"])

            await plan(*pairs[0])  # the analysis, computed and cached
            engine = app.state.engine
            gc.collect()
            rss0, cache0 = rss_bytes(), engine.cache.bytes
            ids = []
            for start, goal in pairs[1 : 1 + near_plans]:  # memory: near plans, new goals
                ids.append((await plan(start, goal))[1])
            gc.collect()
            rss1, cache1 = rss_bytes(), engine.cache.bytes

            # Steps along the near plans just made (no obstacles: the robot follows its plan).
            body = StepCreate.model_validate({})
            step_t: list[float] = []
            for plan_id in ids:
                for _ in range(30):
                    t0 = time.perf_counter()
                    await plans.step(engine, plan_id, body)
                    step_t.append(time.perf_counter() - t0)

            # Time: near and far plans alternated, every goal new (no wave cached for it).
            near_t: list[float] = []
            far_t: list[float] = []
            timed = pairs[1 + near_plans :]
            for i in range(max(len(timed), far_plans)):
                if i < len(timed):
                    near_t.append((await plan(*timed[i]))[0])
                if i < far_plans:
                    far_t.append((await plan((1, 1), (SIZE - 2 - i, SIZE - 2)))[0])
    cells = SIZE * SIZE
    near_ms, far_ms = statistics.median(near_t) * 1e3, statistics.median(far_t) * 1e3
    return {
        "near_ms": near_ms,
        "far_ms": far_ms,
        "ratio": near_ms / far_ms,
        "rss_per_cell_per_plan": (rss1 - rss0) / cells / near_plans,
        "cache_per_cell_per_plan": (cache1 - cache0) / cells / near_plans,
        "rss_mb": (rss1 - rss0) / 1e6,
        "cache_mb": (cache1 - cache0) / 1e6,
        "step_us": statistics.median(step_t) * 1e6,
        "step_p90_us": float(np.percentile(step_t, 90)) * 1e6,
        "near_plans": near_plans,
        "timed_near": len(near_t),
        "timed_far": len(far_t),
    }


def table(label: str, result: dict[str, Any]) -> str:
    r = result
    lines = [
        f"Service at scale, {SIZE}² map, 20 % obstacles, in-process ASGI; CPU: {cpu_model()} "
        f"({label})",
        "",
        "| figure | value |",
        "|---|---|",
        f"| `POST /plan`, goal ~50 cells away (median of {r['timed_near']}) | "
        f"{r['near_ms']:.1f} ms |",
        f"| `POST /plan`, corner to corner (median of {r['timed_far']}) | {r['far_ms']:.0f} ms |",
        f"| near / far | {100 * r['ratio']:.2f} % |",
        f"| RSS after {r['near_plans']} near plans | {r['rss_mb']:.1f} MB "
        f"({r['rss_per_cell_per_plan']:.3f} B per cell per plan) |",
        f"| cache bytes after {r['near_plans']} near plans | {r['cache_mb']:.1f} MB "
        f"({r['cache_per_cell_per_plan']:.3f} B per cell per plan) |",
        f"| in-process step along a near plan | median {r['step_us']:.0f} µs, "
        f"p90 {r['step_p90_us']:.0f} µs |",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--near", type=int, default=20, help="near plans kept (memory)")
    parser.add_argument("--far", type=int, default=3, help="corner-to-corner plans timed")
    parser.add_argument("--timed", type=int, default=10, help="near plans timed")
    parser.add_argument("--label", default="this checkout")
    args = parser.parse_args()
    planner.warm_up()
    result = asyncio.run(run(args.near, args.far, args.timed))
    print(json.dumps({"label": args.label, **result}))
    print(table(args.label, result))


if __name__ == "__main__":
    main()

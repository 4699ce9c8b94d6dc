"""Over HTTP on 127.0.0.1: a 1024 x 1024 map's analysis cold and cached, and step latency.

Starts ``uvicorn service.main:app`` on a free port itself. Run:
``.venv/bin/python benchmarks/service_http.py``; prints times, medians, p99 and ratios.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from typing import Any

import httpx
import numpy as np
from common import ROOT, free_port

STEPS = 1000


def timed(client: httpx.Client, method: str, url: str, body: Any) -> tuple[float, Any]:
    t0 = time.perf_counter()
    r = client.request(method, url, json=body)
    elapsed = (time.perf_counter() - t0) * 1e3
    r.raise_for_status()
    return elapsed, r.json() if r.content else {}


def main() -> None:
    port = free_port()
    server = subprocess.Popen(
        [sys.executable, "-m", "uvicorn", "service.main:app", "--host", "127.0.0.1",
         "--port", str(port), "--log-level", "warning"],
        cwd=ROOT,
    )  # fmt: skip
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=120) as client:
            for _ in range(600):
                try:
                    client.get("/healthz").raise_for_status()
                    break
                except httpx.TransportError:
                    time.sleep(0.1)
            rng = np.random.default_rng(0)
            grid = (rng.random((1024, 1024)) < 0.2).astype(np.uint8)
            grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 0
            rows = ["".join(".@"[v] for v in row) for row in grid.tolist()]
            for name, body in (("rows", {"rows": rows}), ("grid", {"grid": grid.tolist()})):
                ms, info = timed(client, "POST", "/maps", body)
                print(f"POST /maps 1024 x 1024 as {name}: {ms:.0f} ms")
            plan = {"map_id": info["map_id"], "start": [0, 0], "goal": [1023, 1023]}
            cold, p = timed(client, "POST", "/plan", plan)
            cached = [timed(client, "POST", "/plan", plan) for _ in range(20)]
            warm, q = statistics.median(ms for ms, _ in cached), cached[-1][1]
            other, _ = timed(client, "POST", "/plan", {**plan, "goal": [1023, 0]})
            print(
                f"analysis of 1024 x 1024: {p['analysis']['analysis_ms']:.0f} ms "
                f"(cache_hit {p['analysis']['cache_hit']})"
            )
            print(f"POST /plan cold (analysis + wave):   {cold:6.0f} ms")
            print(f"POST /plan cached (median of 20):    {warm:6.1f} ms  ratio {cold / warm:.0f}")
            print(f"POST /plan new goal (wave only):     {other:6.1f} ms")
            assert q["analysis"]["cache_hit"]
            small = {"grid": [[0] * 64] * 64, "start": [0, 0], "goal": [63, 63]}
            small_plan = client.post("/maps", json=small).json()["plan"]["plan_id"]
            for label, plan_id in (("64 x 64", small_plan), ("1024 x 1024", p["plan_id"])):
                times = []
                for seq in range(STEPS):
                    obstacles = rng.integers(1, 60, size=(10, 2)).tolist()
                    ms, _ = timed(
                        client, "POST", f"/plan/{plan_id}/step",
                        {"seq": seq, "dynamic_obstacles": obstacles},
                    )  # fmt: skip
                    times.append(ms)
                times.sort()
                print(
                    f"step on {label} ({STEPS} steps, 10 obstacles): median "
                    f"{statistics.median(times):.2f} ms  p99 {times[int(0.99 * len(times))]:.2f} ms"
                )
    finally:
        server.terminate()
        server.wait(timeout=30)


if __name__ == "__main__":
    main()

"""Fairness over HTTP: one client's step latency, quiet and while another thrashes the service.

Starts ``uvicorn service.main:app`` on a free port (memory store, two API keys, so two tenants)
itself. The quiet client steps one plan on a 256 x 256 map; then the noisy client, with four
threads, uploads new 1024 x 1024 maps (as `rows`) with a start and a goal, plans to random
goals on them and simulates, for ``--seconds``, while the quiet client keeps stepping, with a
cache of ``--cache-mib`` (64) that the noisy maps overflow. Prints both medians and their ratio
(issue 13's target: at most 3). Run:
``.venv/bin/python benchmarks/fairness.py [--seconds 20] [--grid] [--cache-mib 64]``
(``--grid`` uploads maps as 0/1 lists, whose parsing costs the event loop more).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import statistics
import subprocess
import sys
import threading
import time
from typing import Any

import httpx
import numpy as np
import orjson
from common import ROOT, free_port

QUIET, NOISY = "quiet-key", "noisy-key"
JSON = {"content-type": "application/json"}


def random_rows(size: int, seed: int) -> list[str]:
    rng = np.random.default_rng(seed)
    cells = rng.random((size, size)) < 0.2
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = False
    return ["".join("@" if c else "." for c in row) for row in cells]


def step_latencies(
    client: httpx.Client, plan_id: str, count: int, seq: int, position: list[int]
) -> list[float]:
    """``count`` steps, each with a dynamic obstacle on the cell diagonally ahead of the robot:
    most steps replan (the heavy kind of step, which runs on a worker)."""
    times = []
    for i in range(count):
        r, c = position
        obstacle = [min(r + 1, 255), min(c + 1, 255)]
        t0 = time.perf_counter()
        answer = client.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": [obstacle]})
        times.append((time.perf_counter() - t0) * 1e3)
        if answer.status_code != 200:
            raise SystemExit(f"step {seq + i}: {answer.status_code} {answer.text[:200]}")
        position[:] = answer.json()["position"]
        if answer.json()["status"] in ("arrived", "blocked"):
            break
    return times


def thrash(url: str, stop: Any, seed: int, grid: bool) -> None:
    """One noisy client: new big maps (one cell changed from a base map each time, so each is
    new to the service but costs this client no time to make), plans to random goals on them,
    simulations."""
    rng = np.random.default_rng(seed)
    base = random_rows(1024, seed)
    with httpx.Client(base_url=url, headers={"X-API-Key": NOISY}, timeout=120) as c:
        n = 0
        while not stop.is_set():
            n += 1
            rows = list(base)
            r, col = 1 + n // 1000 % 1000, 1 + n % 1000
            rows[r] = rows[r][:col] + ("." if rows[r][col] == "@" else "@") + rows[r][col + 1 :]
            body: dict[str, Any] = {"start": [0, 0], "goal": [1023, 1023]}
            if grid:
                body["grid"] = [[int(ch == "@") for ch in row] for row in rows]
            else:
                body["rows"] = rows
            answer = c.post("/maps", content=orjson.dumps(body), headers=JSON)
            if answer.status_code not in (200, 201):
                continue
            map_id = answer.json()["map_id"]
            for _ in range(3):
                if stop.is_set():
                    break
                goal = [0, int(rng.integers(1, 1023))]
                c.post("/plan", json={"map_id": map_id, "start": [1023, 0], "goal": goal})
            sim = {"start": [0, 0], "goal": [1023, 1023], "dynamic_count": 50}
            c.post(f"/maps/{map_id}/simulate", json=sim)


def noisy(url: str, stop: Any, grid: bool) -> None:
    """The noisy client's four threads, in a process of their own: the quiet client's timing
    does not share a GIL with them."""
    threads = [threading.Thread(target=thrash, args=(url, stop, i, grid)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--grid", action="store_true")
    parser.add_argument("--cache-mib", type=int, default=64, help="PLANNER_CACHE_BYTES in MiB")
    parser.add_argument("--pool", type=int, default=2, help="PLANNER_POOL_SIZE")
    args = parser.parse_args()
    port = free_port()
    env = {
        **os.environ,
        "PLANNER_API_KEYS": f"{QUIET},{NOISY}",
        "PLANNER_POOL_SIZE": str(args.pool),
    }
    # A cache the noisy client's maps overflow within seconds: the quiet plan's analysis is
    # evicted unless each key keeps its share.
    env["PLANNER_CACHE_BYTES"] = str(args.cache_mib << 20)
    server = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "uvicorn",
            "service.main:app",
            "--port",
            str(port),
            "--log-level",
            "warning",
        ],
        cwd=ROOT,
        env=env,
        stderr=subprocess.DEVNULL,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        with httpx.Client(base_url=url, headers={"X-API-Key": QUIET}, timeout=120) as c:
            for _ in range(600):
                try:
                    c.get("/healthz")
                    break
                except httpx.TransportError:
                    time.sleep(0.1)
            rows = random_rows(256, 1)
            body = {"rows": rows, "start": [0, 0], "goal": [255, 255], "preset": "shortest"}
            r = c.post("/maps", json=body)
            r.raise_for_status()
            plan_id = r.json()["plan"]["plan_id"]
            # A long enough episode: back and forth is not possible, so one plan per phase.
            quiet = step_latencies(c, plan_id, 150, 0, [0, 0])
            plan_id = c.post("/maps", json=body).json()["plan"]["plan_id"]
            position = [0, 0]
            stop = multiprocessing.Event()
            noise = multiprocessing.Process(target=noisy, args=(url, stop, args.grid))
            noise.start()
            time.sleep(2.0)  # the thrashing is under way
            loaded: list[float] = []
            t_end = time.monotonic() + args.seconds
            while time.monotonic() < t_end:
                done = step_latencies(c, plan_id, 20, len(loaded), position)
                loaded += done
                if len(done) < 20:  # arrived or blocked: a new plan, same map
                    plan_id = c.post("/maps", json=body).json()["plan"]["plan_id"]
                    position = [0, 0]
            stop.set()
            noise.join(timeout=300)
        q, lo = statistics.median(quiet), statistics.median(loaded)
        print(f"quiet step median {q:.2f} ms over {len(quiet)} steps (most replan)")
        print(
            f"loaded step median {lo:.2f} ms over {len(loaded)} steps (p90 "
            f"{np.percentile(loaded, 90):.2f} ms)"
        )
        print(f"ratio {lo / q:.2f} (target <= 3); maps as {'grid' if args.grid else 'rows'}")
    finally:
        server.terminate()
        server.wait(timeout=30)


if __name__ == "__main__":
    main()

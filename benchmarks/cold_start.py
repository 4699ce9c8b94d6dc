"""How long ``python -m service`` takes to be ready: with an empty numba cache (a fresh
``NUMBA_CACHE_DIR``, as a new container or a fresh clone has), then again with the cache that
first start filled.

For each start: seconds of wall time from the spawn to the first ``200`` of ``/readyz``, the
CPU seconds the process used until then (less sensitive to a busy machine than the wall time),
the ``warmup_seconds`` it logged, and, where it logs one, when its background warm-up (the
kernels serving does not need first) ended. Run:
``.venv/bin/python benchmarks/cold_start.py [--runs 2]``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
from common import ROOT, TICK, free_port

BACKGROUND = "warmed up the rest"
"""The service's log message when its background warm-up ends."""


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime, stime


def start(cache: Path, log: Path, timeout: float = 600) -> dict[str, float | None]:
    """One start with ``cache`` as the numba cache: its figures (see the module's docstring)."""
    port = free_port()
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(cache),
        "PLANNER_HOST": "127.0.0.1",
        "PLANNER_PORT": str(port),
    }
    began = time.perf_counter()
    with log.open("wb") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "service"], cwd=ROOT, env=env, stdout=out, stderr=out
        )
    try:
        with httpx.Client(trust_env=False) as client:
            while True:
                if process.poll() is not None or time.perf_counter() - began > timeout:
                    raise SystemExit(f"the service did not get ready:\n{log.read_text()[-2000:]}")
                try:
                    if client.get(f"http://127.0.0.1:{port}/readyz", timeout=5).status_code == 200:
                        break
                except httpx.TransportError:
                    pass
                time.sleep(0.02)
        ready = time.perf_counter() - began
        cpu = _cpu_seconds(process.pid)
        background = None
        while time.perf_counter() - began < timeout:  # the background warm-up, if any
            lines = [json.loads(x) for x in log.read_text().splitlines() if x.startswith("{")]
            done = [x for x in lines if x.get("message") == BACKGROUND]
            if done:
                background = float(done[0]["background_seconds"])
                break
            if not any(x.get("message") == "warming up the rest" for x in lines):
                break  # a service that warms everything before it is ready
            time.sleep(0.2)
        warmup = next(
            (x.get("warmup_seconds") for x in lines if x.get("message") == "warmed up"), None
        )
        return {"ready_s": ready, "cpu_s": cpu, "warmup_s": warmup, "background_s": background}
    finally:
        process.terminate()
        process.wait(timeout=60)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1, help="cold + warm pairs (default 1)")
    runs = parser.parse_args().runs
    rows: dict[str, list[dict[str, float | None]]] = {"empty cache": [], "warm cache": []}
    for _ in range(runs):
        with tempfile.TemporaryDirectory(prefix="numba-cache-") as folder:
            cache = Path(folder) / "cache"
            log = Path(folder) / "service.log"
            rows["empty cache"].append(start(cache, log))
            rows["warm cache"].append(start(cache, log))
    print(f"python -m service, {runs} run(s) of each; CPU: {os.cpu_count()} cores")
    print(f"{'':12} {'ready s':>8} {'CPU s':>7} {'warmup s':>9} {'background s':>13}")
    for name, found in rows.items():

        def median(key: str, found: list[dict[str, float | None]] = found) -> str:
            values = [float(v) for row in found if (v := row[key]) is not None]
            return f"{statistics.median(values):.2f}" if values else "-"

        print(
            f"{name:12} {median('ready_s'):>8} {median('cpu_s'):>7} {median('warmup_s'):>9}"
            f" {median('background_s'):>13}"
        )


if __name__ == "__main__":
    main()

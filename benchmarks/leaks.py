"""Memory over HTTP: the server's RSS across loads that grew it without bound before issue 13.

Starts ``uvicorn service.main:app`` on a free port with a 4 MiB map store and prints its RSS
(``/proc/<pid>/status``) before and after: 2000 steps to unknown plans with 8 KB ids, 60 new
1024 x 1024 maps (60 MiB of cells), and a 67 MB step body (refused from its size). Run:
``.venv/bin/python benchmarks/leaks.py``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import httpx
import numpy as np
from common import ROOT, free_port


def rss_mib(pid: int) -> float:
    status = Path(f"/proc/{pid}/status").read_text()
    kib = next(line.split()[1] for line in status.splitlines() if line.startswith("VmRSS"))
    return int(kib) / 1024


def _gauges(c: httpx.Client, *names: str) -> str:
    """``name value`` of those gauges, as ``GET /metrics`` gives them."""
    lines = c.get("/metrics").text.splitlines()
    return ", ".join(line for line in lines if line.split(" ", 1)[0] in names)


def main() -> None:
    port = free_port()
    env = {**os.environ, "PLANNER_MAP_STORE_BYTES": str(4 << 20), "PLANNER_POOL_SIZE": "2"}
    args = [sys.executable, "-m", "uvicorn", "service.main:app", "--port", str(port)]
    server = subprocess.Popen([*args, "--log-level", "warning"], cwd=ROOT, env=env)
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=120) as c:
            for _ in range(600):
                try:
                    c.get("/healthz")
                    break
                except httpx.TransportError:
                    time.sleep(0.1)
            pid = server.pid
            for i in range(100):  # warm
                c.post(f"/plan/{'w' * 8000}{i}/step", json={})
            before = rss_mib(pid)
            for i in range(2000):
                assert c.post(f"/plan/{'q' * 8000}{i}/step", json={}).status_code == 404
            print(f"2000 steps to unknown 8 KB ids: RSS {before:.1f} -> {rss_mib(pid):.1f} MiB")
            rng = np.random.default_rng(0)
            before = rss_mib(pid)
            codes: dict[int, int] = {}
            for _ in range(60):
                cells = rng.random((1024, 1024)) < 0.2
                rows = ["".join("@" if x else "." for x in row) for row in cells]
                code = c.post("/maps", json={"rows": rows}).status_code
                codes[code] = codes.get(code, 0) + 1
            print(
                f"60 new 1024^2 maps, 4 MiB store: RSS {before:.1f} -> {rss_mib(pid):.1f} MiB "
                f"(answers {codes}; {_gauges(c, 'planner_maps', 'planner_cache_bytes')})"
            )
            before = rss_mib(pid)
            body = b'{"dynamic_obstacles": [' + b"[1, 1], " * 8_400_000 + b"[1, 1]]}"
            t0 = time.perf_counter()
            r = c.post("/plan/x/step", content=body, headers={"content-type": "application/json"})
            took = time.perf_counter() - t0
            print(
                f"a {len(body) / 1e6:.0f} MB step body: {r.status_code} in {took:.2f} s, "
                f"RSS {before:.1f} -> {rss_mib(pid):.1f} MiB"
            )
    finally:
        server.terminate()
        server.wait(timeout=30)


if __name__ == "__main__":
    main()

"""Steps over HTTP, driven by ``wrk``, as a ratio to a bare FastAPI JSON echo in the same run.

Starts the real service (``python -m service``, configured by ``PLANNER_*``) on the memory store
and, when ``redis-server`` is installed, on a private Redis; starts the echo
(``benchmarks/bare_app.py``); uploads one 1024² map (10 % random obstacles and walls that make
the way to the goal a long serpentine, so no robot arrives during a run), then for each case
creates fresh plans and runs ``wrk`` with ``benchmarks/http_steps.lua`` (10 random dynamic
obstacles per step). The echo is run with the same bodies and connections just before each of
the store's cases. Prints a markdown table: requests/s, ratio to the echo, p50/p99, non-2xx
(and socket errors: a run with any is not a result), the server process's CPU per request (user +
system time from ``/proc/PID/stat`` before and after the run) and the requests a core serves at
that cost, for both sides, and the CPU.

    .venv/bin/python benchmarks/http_steps.py [--seconds 5] [--repeats 1] [--no-redis|--only-redis]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np
from common import ROOT, Process, free_port, service

from service.config import Settings

LUA = ROOT / "benchmarks" / "http_steps.lua"
SIZE = 1024
CASES = (  # (name, connections, plans, wrk mode)
    ("c=1, one plan", 1, 1, "plan"),
    ("c=16, 16 plans", 16, 16, "plan"),
    ("c=16, one plan", 16, 1, "shared"),
)


def echo() -> Process:
    """The bare echo on uvicorn with the service's own HTTP parser (``PLANNER_HTTP_PARSER``,
    default h11): both sides of a ratio ride the same server road."""
    port = free_port()
    parser = os.environ.get("PLANNER_HTTP_PARSER", Settings.model_fields["http_parser"].default)
    argv = [sys.executable, "-m", "uvicorn", "benchmarks.bare_app:app", "--host", "127.0.0.1"]
    argv += ["--port", str(port), "--log-level", "warning", "--no-access-log", "--http", parser]
    return Process(argv, port)


def serpentine_map(seed: int = 0) -> tuple[list[str], list[int], list[int]]:
    """10 % random obstacles, and a wall every 32 rows open at alternate ends: the path from the
    top-left to the bottom-left corner runs ~32,000 cells."""
    rng = np.random.default_rng(seed)
    grid = rng.random((SIZE, SIZE)) < 0.1
    for k, r in enumerate(range(31, SIZE - 1, 32)):
        grid[r, :] = True
        gap = slice(SIZE - 24, SIZE) if k % 2 == 0 else slice(0, 24)
        grid[r, gap] = False
    grid[:4, :4] = False
    grid[-4:, :4] = False
    rows = ["".join(".@"[int(v)] for v in row) for row in grid]
    return rows, [1, 1], [SIZE - 2, 1]


def wrk(url: str, connections: int, seconds: int, ids: Path, mode: str) -> dict[str, float]:
    run = subprocess.run(
        ["wrk", "-t", str(connections), "-c", str(connections), "-d", f"{seconds}s",
         "--latency", "-s", str(LUA), url, "--", str(ids), mode],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    for line in run.stderr.splitlines()[:5]:  # the first failed answers, if any
        print(f"  {line}", file=sys.stderr)
    out = run.stdout
    scale = {"us": 1e-3, "ms": 1.0, "s": 1e3}
    result = {"errors": 0.0, "requests": 0.0}
    for line in out.splitlines():
        words = line.split()
        if line.startswith("Requests/sec:"):
            result["rps"] = float(words[1])
        elif words[:1] in (["50%"], ["99%"]):
            unit = words[1].lstrip("0123456789.")
            result[f"p{words[0][:-1]}_ms"] = float(words[1][: -len(unit)]) * scale[unit]
        elif "requests in" in line:
            result["requests"] = float(words[0])
        elif line.strip().startswith("Non-2xx or 3xx responses:"):
            result["errors"] += float(words[-1])
        elif line.strip().startswith("Socket errors:"):
            result["errors"] += sum(float(w.rstrip(",")) for w in words[3::2])
    return result


def measured(server: Process, *args: Any) -> dict[str, float]:
    before = server.cpu_seconds()
    result = wrk(server.url, *args)
    used = server.cpu_seconds() - before
    result["cpu_us"] = 1e6 * used / max(1.0, result["requests"])
    return result


def run_store(
    name: str, env: dict[str, str], bare: Process, seconds: int, repeats: int, tmp: Path
) -> list[dict[str, Any]]:
    rows, start, goal = serpentine_map()
    out = []
    with service(env) as ours:
        ours.wait("/healthz")
        with httpx.Client(base_url=ours.url, timeout=300) as client:
            made = client.post("/maps", json={"rows": rows})
            made.raise_for_status()
            body = {"map_id": made.json()["map_id"], "start": start, "goal": goal}
            client.post("/plan", json=body).raise_for_status()  # analysis cached
            for case, connections, plans, mode in CASES:
                best: dict[str, dict[str, float]] = {}
                for _ in range(repeats):
                    ids = tmp / "plans"
                    made_ids = []
                    for _ in range(plans):  # fresh plans each run: seq starts at 0
                        answer = client.post("/plan", json=body)
                        answer.raise_for_status()
                        made_ids.append(answer.json()["plan_id"])
                    ids.write_text("\n".join(made_ids) + "\n")
                    runs = {
                        "bare": measured(bare, connections, seconds, ids, "echo"),
                        "ours": measured(ours, connections, seconds, ids, mode),
                    }
                    for who, result in runs.items():
                        if who not in best or result["rps"] > best[who]["rps"]:
                            best[who] = result
                out.append({"store": name, "case": case, **best})
                print(f"  {name} {case}: {best}", file=sys.stderr, flush=True)
    return out


def cpu_model() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return "unknown CPU"
    facts = dict(line.split(":", 1) for line in out.splitlines() if ":" in line)
    model = facts.get("Model name", "unknown").strip()
    return f"{model}, {facts.get('CPU(s)', '?').strip()} CPUs"


def table(results: list[dict[str, Any]]) -> str:
    lines = [
        "| store | case | steps/s | echo/s | ratio | p50 ms | p99 ms | non-2xx | "
        "CPU µs/step | CPU µs/echo | steps/s a core | echoes/s a core |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in results:
        ours, bare = r["ours"], r["bare"]
        lines.append(
            f"| {r['store']} | {r['case']} | {ours['rps']:.0f} | {bare['rps']:.0f} | "
            f"{ours['rps'] / bare['rps']:.2f} | {ours['p50_ms']:.2f} | {ours['p99_ms']:.2f} | "
            f"{ours['errors']:.0f} | {ours['cpu_us']:.0f} | {bare['cpu_us']:.0f} | "
            f"{1e6 / max(ours['cpu_us'], 1e-9):.0f} | {1e6 / max(bare['cpu_us'], 1e-9):.0f} |"
        )
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=1, help="best of this many runs")
    only = parser.add_mutually_exclusive_group()
    only.add_argument("--no-redis", action="store_true")
    only.add_argument("--only-redis", action="store_true")
    args = parser.parse_args()
    if shutil.which("wrk") is None:
        print("wrk is not installed (Debian: apt-get install -y wrk)", file=sys.stderr)
        return 1
    results = []
    with tempfile.TemporaryDirectory() as name, echo() as bare:
        tmp = Path(name)
        bare.wait("/docs")
        if not args.only_redis:
            results += run_store("memory", {}, bare, args.seconds, args.repeats, tmp)
        redis = shutil.which("redis-server")
        if redis and not args.no_redis:
            port = free_port()
            argv = [redis, "--port", str(port), "--bind", "127.0.0.1", "--save", ""]
            argv += ["--appendonly", "no"]
            with Process(argv, port):
                time.sleep(0.5)
                env = {"PLANNER_STORE_URL": f"redis://127.0.0.1:{port}/0"}
                results += run_store("redis", env, bare, args.seconds, args.repeats, tmp)
    print(f"CPU: {cpu_model()}; wrk {args.seconds} s a run, best of {args.repeats}.\n")
    print(table(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

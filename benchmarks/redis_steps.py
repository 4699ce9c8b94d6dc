"""Steps through ``RedisStore.update_plan`` alone (no HTTP), against a private ``redis-server``.

``c`` tasks each step a plan of their own as fast as they can for a few seconds (uvloop, as the
service runs); prints steps/s and this process's CPU µs per step (Redis's own CPU apart). For
comparing ways of talking to Redis, not a target of its own.

    .venv/bin/python benchmarks/redis_steps.py [--seconds 3] [--repeats 3] [--clients 1 16]
"""

from __future__ import annotations

import argparse
import asyncio
import shutil
import subprocess
import tempfile
import time

import uvloop
from common import free_port

from service.stores import PlanRecord, RedisStore
from service.stores.base import Update

PAD = "x" * 600
"""A record of a step's usual size (~0.7 KB of JSON)."""


async def decide(record: PlanRecord) -> Update[int]:
    k = record["n"] + 1
    return Update(k, {"n": k, "pad": PAD}, [(k, 0)], ("planner:events:bench", b'{"n":%d}' % k))


async def run(url: str, clients: int, seconds: float) -> tuple[float, float]:
    """Steps/s and CPU µs a step, ``clients`` plans stepped at once."""
    store = RedisStore(url, ttl_seconds=600)
    try:
        plans = [f"bench{clients}-{i}" for i in range(clients)]
        for plan_id in plans:
            await store.put_plan(plan_id, {"n": 0, "pad": PAD})
            await store.update_plan(plan_id, decide)  # connected, script loaded
        done = 0
        end = time.monotonic() + seconds

        async def client(plan_id: str) -> None:
            nonlocal done
            while time.monotonic() < end:
                await store.update_plan(plan_id, decide)
                done += 1

        began, cpu = time.monotonic(), time.process_time()
        await asyncio.gather(*(client(p) for p in plans))
        wall, cpu = time.monotonic() - began, time.process_time() - cpu
        for plan_id in plans:
            await store.delete_plan(plan_id)
        return done / wall, cpu / done * 1e6
    finally:
        await store.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--clients", type=int, nargs="+", default=[1, 16])
    args = parser.parse_args()
    binary = shutil.which("redis-server")
    if binary is None:
        raise SystemExit("redis-server is not on PATH")
    port = free_port()
    with tempfile.TemporaryDirectory() as tmp:
        argv = [binary, "--port", str(port), "--bind", "127.0.0.1", "--save", "", "--dir", tmp]
        server = subprocess.Popen(argv, stdout=subprocess.DEVNULL)
        try:
            time.sleep(0.3)
            url = f"redis://127.0.0.1:{port}/0"
            print("| clients | steps/s (best) | CPU µs/step (best) |")
            print("|---:|---:|---:|")
            for clients in args.clients:
                runs = [uvloop.run(run(url, clients, args.seconds)) for _ in range(args.repeats)]
                rate = max(r for r, _ in runs)
                cost = min(c for _, c in runs)
                print(f"| {clients} | {rate:,.0f} | {cost:.0f} |", flush=True)
        finally:
            server.terminate()
            server.wait(timeout=30)


if __name__ == "__main__":
    main()

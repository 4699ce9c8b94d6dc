"""Steps on the Redis store over HTTP on a robot map whose live layer holds marks: the round
trips a step makes to Redis (counted with ``MONITOR``) and the step's latency.

A ``python -m service`` (pool of 1) on a private ``redis-server`` serves ``depot``; 20 scans
of pallets (``live.py``'s) mark its live layer (marks lasting an hour), then robots step: a
lone robot, two robots of a fleet, and a fleet robot whose steps alternate between two
replicas. ``--code DIR`` serves another checkout of the repository (to compare with an older
version of the store).

    .venv/bin/python benchmarks/redis_round_trips.py [--steps 200] [--code DIR]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import redis
from common import ROOT, free_port, ros_maps
from live import scan_body, upload

import planner


@contextmanager
def replica(code: Path, url: str) -> Iterator[str]:
    """``python -m service`` from ``code``, on Redis at ``url``."""
    port = free_port()
    env = {
        **os.environ, "PYTHONPATH": str(code), "PLANNER_HOST": "127.0.0.1",
        "PLANNER_PORT": str(port), "PLANNER_STORE_URL": url, "PLANNER_POOL_SIZE": "1",
        "PLANNER_OBSTACLE_PERSISTENCE_SECONDS": "3600",
    }  # fmt: skip
    process = subprocess.Popen(
        [sys.executable, "-m", "service"], cwd=code, env=env, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 600
        while True:
            try:
                if httpx.get(base + "/readyz", timeout=5).json()["pool"]["warm"]:
                    break
            except httpx.TransportError:
                pass
            if process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"{base} did not start")
            time.sleep(0.2)
        yield base
    finally:
        process.terminate()
        process.wait(timeout=30)


class Trips(threading.Thread):
    """Round trips the services make to Redis, counted by ``MONITOR``: each command a client
    sends (a script's own commands apart, and a new connection's greeting), a transaction
    (``MULTI`` ... ``EXEC``) as one. Steps sent one at a time: none share a pipeline."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self._redis = redis.Redis(port=port)
        self._counting = threading.Event()
        self._pinged = threading.Event()
        self.trips: dict[str, int] = {}
        self._in_multi: set[str] = set()
        self.start()

    def run(self) -> None:
        with self._redis.monitor() as monitor:  # type: ignore[no-untyped-call]
            while True:
                try:
                    command = monitor.next_command()
                except redis.TimeoutError:  # idle: nothing sent meanwhile
                    continue
                except redis.ConnectionError:  # the server stopped
                    return
                word = command["command"].split(" ", 1)[0].upper()
                if word == "PING":
                    self._pinged.set()
                if not self._counting.is_set() or command["client_type"] == "lua":
                    continue
                client = f"{command['client_address']}:{command['client_port']}"
                if word in ("PING", "HELLO", "CLIENT", "SELECT") or client in self._in_multi:
                    if word == "EXEC":
                        self._in_multi.discard(client)
                    continue
                if word == "MULTI":
                    self._in_multi.add(client)
                self.trips[word] = self.trips.get(word, 0) + 1

    @contextmanager
    def counting(self) -> Iterator[dict[str, int]]:
        self.trips = {}
        self._counting.set()
        try:
            yield self.trips
        finally:
            self._pinged.clear()
            self._redis.ping()  # once the monitor sees it, it has seen every command before
            self._pinged.wait(10)
            self._counting.clear()


def measure(name: str, trips: Trips, steps: list[tuple[httpx.Client, str]]) -> None:
    """Each of ``steps`` (a client, a plan) stepped once with its plan's next ``seq``, in
    turn."""
    times = []
    with trips.counting() as sent:
        for client, plan_id in steps:
            seq = SEQS[plan_id] = SEQS.get(plan_id, 0) + 1
            t0 = time.perf_counter()
            answer = client.post(f"/plan/{plan_id}/step", json={"seq": seq})
            times.append((time.perf_counter() - t0) * 1e3)
            answer.raise_for_status()
    words = ", ".join(f"{k} {v / len(steps):.2f}" for k, v in sorted(sent.items()))
    print(
        f"{name}: {sum(sent.values()) / len(steps):.2f} round trips a step ({words}); step "
        f"over HTTP median {statistics.median(times):.2f} ms, p99 "
        f"{np.percentile(times, 99):.2f} ms"
    )


SEQS: dict[str, int] = {}
"""Each plan's last ``seq``."""


def first_steps(client: httpx.Client, plans: list[str]) -> None:
    for plan_id in plans:
        client.post(f"/plan/{plan_id}/step", json={"seq": 0}).raise_for_status()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--code", type=Path, default=ROOT)
    args = parser.parse_args()
    binary = shutil.which("redis-server")
    if binary is None:
        raise SystemExit("redis-server is not on PATH")
    folder = ros_maps()
    robot_map = planner.read_ros_map(folder / "depot.yaml")
    rng = np.random.default_rng(7)
    scans = [scan_body(robot_map, rng)[0] for _ in range(20)]
    port = free_port()
    server = subprocess.Popen(
        [binary, "--port", str(port), "--save", "", "--appendonly", "no"],
        stdout=subprocess.DEVNULL,
    )
    url = f"redis://127.0.0.1:{port}/0"
    with ExitStack() as stack:
        stack.callback(server.wait)
        stack.callback(server.terminate)
        time.sleep(0.5)
        a_url = stack.enter_context(replica(args.code, url))
        b_url = stack.enter_context(replica(args.code, url))
        a = stack.enter_context(httpx.Client(base_url=a_url, trust_env=False, timeout=60))
        b = stack.enter_context(httpx.Client(base_url=b_url, trust_env=False, timeout=60))
        map_id = upload(a, folder)
        for raw in scans:
            headers = {"content-type": "application/json"}
            a.post(f"/maps/{map_id}/observations", content=raw, headers=headers).raise_for_status()
        marks = len(a.get(f"/maps/{map_id}/live").json()["cells"])
        print(f"depot, {marks} live marks; {args.code.name}; redis-py {redis.__version__}")
        ends = [((3.0, 7.5), (27.0, 7.5)), ((27.0, 9.5), (3.0, 9.5))]
        plans = []
        for i, (start, goal) in enumerate([ends[0], *ends]):
            body: dict[str, Any] = {
                "map_id": map_id, "start": dict(zip("xy", start, strict=True)),
                "goal": dict(zip("xy", goal, strict=True)), "robot_radius": 0.22,
            }  # fmt: skip
            if i:
                body["fleet"] = "bench"
            answer = a.post("/plan", json=body)
            answer.raise_for_status()
            plans.append(answer.json()["plan_id"])
        lone, one, two = plans
        first_steps(a, plans)
        trips = Trips(port)  # watching from now: the map and the scans are big commands
        measure("a lone robot, one replica", trips, [(a, lone)] * args.steps)
        half = args.steps // 2
        measure("two fleet robots, one replica", trips, [(a, one), (a, two)] * half)
        measure("a fleet robot on two replicas in turn", trips, [(b, one), (a, one)] * half)


if __name__ == "__main__":
    main()

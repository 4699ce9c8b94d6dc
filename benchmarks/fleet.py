"""Fleets over HTTP (docs/fleets.md): N robots of one fleet with seeded starts and goals, stepped
in ticks (the steps of a tick sent concurrently in a random order), on a map with a one-lane
corridor, on random rooms and corridors, on the largest shared ROS map and on a Moving AI grid,
against the memory store (one server) and Redis (two replicas, a robot's steps alternating).

Robots skip ticks (``--skip``) and fall silent for 5-30 ticks (``--pause``). Counts, after every
tick: collisions (two robots whose paths until their next step, their last answers' poses, come
closer than the sum of their radii); at the end, whether all arrived within 4 x the sum of their
solo path lengths + 200 ticks (else a deadlock), and the step's p50/p99: the client's (round trip,
queue included), the server's own (its ``planner_http_request_duration_seconds`` histogram on
``/metrics``, read before and after each run: arrival to the end of the answer, interpolated in
its buckets), the client's CPU time per step and the servers' (``/proc/PID/stat``).

    .venv/bin/python benchmarks/fleet.py [--seeds 20] [--rooms 20] [--robots 16]
        [--store memory redis] [--client aiohttp httpx] [--scenarios swap2 swap4 rooms depot grid]
        [--in-process]

``--client`` says who sends the steps (httpx uploads the maps and creates the plans either
way): ``aiohttp``, the default (:class:`AiohttpStepper`: an aiohttp session of kept-alive
connections, bodies encoded by orjson), or ``httpx``, whose own work on two cores shared with
the server is most of the latency it sees (docs/performance.md#fleets).

The scenarios are benchmarks/fleet_scenarios.py's; tests/service/test_fleets.py drives the same
code at smaller sizes.
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import itertools
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import httpx
import numpy as np
import orjson
import uvloop
from common import Process, free_port, ros_maps, service
from fleet_scenarios import (
    Scenario,
    corridor_scenario,
    map_body,
    random_corridor_scenario,
    random_scenario,
)

import planner
from planner.fleets import segment_distances
from service.ops.metrics import BUCKETS

if TYPE_CHECKING:
    import aiohttp


@dataclass
class Outcome:
    """What one run of a scenario counted."""

    robots: int
    arrived: int = 0
    ticks: int = 0
    budget: int = 0
    collisions: list[str] = field(default_factory=list)
    step_ms: list[float] = field(default_factory=list)
    client_cpu_s: float = 0.0
    """The client process's CPU time (user and system) while the ticks' steps were in flight."""
    server_buckets: list[float] = field(default_factory=list)
    """Steps answered 200 in each bucket of the servers' histogram (the last: over them all)."""
    server_cpu_s: float = 0.0
    """The servers' CPU time (user and system) over the run (the map and plans too)."""
    errors: list[str] = field(default_factory=list)

    @property
    def deadlock(self) -> bool:
        return self.arrived < self.robots


async def run(
    clients: Sequence[httpx.AsyncClient],
    scenario: Scenario,
    *,
    fleet: str,
    seed: int,
    max_ticks: int | None = None,
    steppers: Sequence[Any] | None = None,
    skip: float = 0.0,
    pause: float = 0.0,
    spread_ms: float = 0.0,
) -> Outcome:
    """Upload the map, create the fleet's plans, then tick until all arrived or the budget is
    spent: each tick, the robots step concurrently in a random order (a robot's steps alternate
    between ``clients``, or ``steppers``: clients of the same URLs with httpx's ``post``, such
    as :class:`AiohttpStepper`); with ``skip``, each robot sits a tick out with that chance, and
    with ``pause``, falls silent for 5-30 ticks; with ``spread_ms``, each robot's step of a tick
    is sent at a random moment within that many milliseconds of the tick's start (robots on
    their own clocks, rather than all at once). A robot drives its last answer's poses until it
    steps again: after every tick, any two robots' poses must keep the sum of their radii.
    Delete the plans at the end."""
    m, radius = scenario.robot_map, scenario.radius
    answer = await clients[0].post("/maps", json=map_body(m))
    answer.raise_for_status()
    map_id = answer.json()["map_id"]
    plan_ids, solo = [], 0
    outcome = Outcome(len(scenario.robots))
    try:
        for start, goal in scenario.robots:
            body = {"map_id": map_id, "start": list(start), "goal": list(goal),
                    "robot_radius": radius, "fleet": fleet}  # fmt: skip
            made = await clients[0].post("/plan", json=body)
            if made.status_code != 201:
                raise RuntimeError(f"plan {body}: {made.status_code} {made.text[:300]}")
            plan_ids.append(made.json()["plan_id"])
            solo += len(made.json()["preview"]["path"]) - 1
        outcome.budget = 4 * solo + 200 if max_ticks is None else max_ticks
        rng = np.random.default_rng(seed)
        centers = m.frame.centers(np.array([s for s, _ in scenario.robots]))
        driving = [np.array([xy]) for xy in centers]  # each robot's poses until it steps again
        done = [False] * len(plan_ids)
        seqs = [0] * len(plan_ids)
        silent = [0] * len(plan_ids)
        for tick in range(outcome.budget):
            order = [int(i) for i in rng.permutation(len(plan_ids))]
            stepping = []
            for i in order:
                if silent[i]:
                    silent[i] -= 1
                elif pause and rng.random() < pause:
                    silent[i] = int(rng.integers(5, 31))
                elif not (skip and rng.random() < skip):
                    stepping.append(i)
            answers: dict[int, dict[str, Any]] = {}
            delays = rng.uniform(0.0, spread_ms / 1000.0, len(plan_ids)) if spread_ms else None

            async def step(
                i: int, tick: int = tick, answers: dict[int, Any] = answers, delays: Any = delays
            ) -> None:
                client = (steppers or clients)[(tick + i) % len(clients)]
                if delays is not None:
                    await asyncio.sleep(float(delays[i]))
                t0 = time.perf_counter()
                got = await client.post(f"/plan/{plan_ids[i]}/step", json={"seq": seqs[i]})
                outcome.step_ms.append((time.perf_counter() - t0) * 1000)
                if got.status_code != 200:
                    outcome.errors.append(f"tick {tick} robot {i}: {got.status_code} {got.text}")
                    return
                seqs[i] += 1
                answers[i] = got.json()

            cpu = time.process_time()
            await asyncio.gather(*(step(i) for i in stepping))
            outcome.client_cpu_s += time.process_time() - cpu
            for i, a in answers.items():
                driving[i] = np.array([[p["x"], p["y"]] for p in a["poses"]]).reshape(-1, 2)
                done[i] = a["status"] == "arrived"
            outcome.ticks = tick + 1
            _check(outcome, tick, driving, radius)
            if all(done):
                break
        outcome.arrived = sum(done)
    finally:
        if os.environ.get("FLEET_DEBUG"):
            print((await clients[0].get(f"/fleets/{fleet}")).json(), file=sys.stderr)
        for plan_id in plan_ids:
            await clients[0].delete(f"/plan/{plan_id}")
    return outcome


@dataclass(frozen=True)
class Answer:
    """The part of httpx's ``Response`` that :func:`run` reads of a step's answer."""

    status_code: int
    content: bytes

    @property
    def text(self) -> str:
        return self.content.decode()

    def json(self) -> Any:
        return orjson.loads(self.content)


JSON_HEADERS = {"content-type": "application/json"}


class AiohttpStepper:
    """httpx's ``post(path, json=...)`` over an aiohttp session: kept-alive HTTP/1.1
    connections to one server (at most ``limit`` at once), the body encoded by orjson. A load
    generator that costs the client a fraction of httpx's CPU time a request, so that the latency
    it sees is less its own work. Made inside a running event loop; :meth:`aclose` it there.
    aiohttp is the bench extra's (imported here: the tests load this module without it)."""

    def __init__(self, url: str, *, limit: int = 64, timeout: float = 60) -> None:
        import aiohttp

        self._session: aiohttp.ClientSession = aiohttp.ClientSession(
            url,
            connector=aiohttp.TCPConnector(limit=limit),
            timeout=aiohttp.ClientTimeout(total=timeout),
            headers=JSON_HEADERS,
        )

    async def post(self, path: str, json: Any) -> Answer:
        async with self._session.post(path, data=orjson.dumps(json)) as got:
            return Answer(got.status, await got.read())

    async def aclose(self) -> None:
        await self._session.close()


def _check(outcome: Outcome, tick: int, driving: list[Any], radius: float) -> None:
    """Count the pairs of robots whose poses (the polylines they drive until their next step)
    come closer than the sum of their radii (pairs whose boxes are farther apart skipped)."""
    n = len(driving)
    low = np.array([d.min(axis=0) for d in driving]) - 2 * radius
    high = np.array([d.max(axis=0) for d in driving]) + 2 * radius
    for i in range(n):
        near = np.nonzero(np.all((low[i + 1 :] <= high[i]) & (high[i + 1 :] >= low[i]), axis=1))[0]
        for j in near + i + 1:
            if _polylines_apart(driving[i], driving[j]) < 2 * radius - 1e-6:
                outcome.collisions.append(f"tick {tick}: robots {i} and {j} closer than 2r")


def _polylines_apart(a: Any, b: Any) -> float:
    """The least distance between two polylines (``(n, 2)`` points; one point: a point)."""
    a0, a1 = (a[:-1], a[1:]) if len(a) > 1 else (a, a)
    b0, b1 = (b[:-1], b[1:]) if len(b) > 1 else (b, b)
    return float(min(segment_distances(p, q, b0, b1).min() for p, q in zip(a0, a1, strict=False)))


def _percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


# -- servers ---------------------------------------------------------------------------------


STEP_ROUTE = ("POST", "/plan/{plan_id}/step", "200")


async def step_buckets(client: httpx.AsyncClient) -> list[float]:
    """The server's count of steps answered 200 in each bucket of its request-duration
    histogram, not cumulative (the last: over every bound), from ``GET /metrics``."""
    from prometheus_client.parser import text_string_to_metric_families

    text = (await client.get("/metrics")).text
    cumulative: dict[float, float] = {}
    for family in text_string_to_metric_families(text):
        if family.name != "planner_http_request_duration_seconds":
            continue
        for sample in family.samples:
            labels = sample.labels
            key = (labels.get("method"), labels.get("route"), labels.get("status"))
            if sample.name.endswith("_bucket") and key == STEP_ROUTE:
                cumulative[float(labels["le"])] = sample.value
    bounds = sorted(cumulative)
    if not bounds:
        return [0.0] * (len(BUCKETS) + 1)
    assert tuple(bounds[:-1]) == BUCKETS, bounds
    counts = [cumulative[b] for b in bounds]
    return [counts[0]] + [b - a for a, b in itertools.pairwise(counts)]


def bucket_percentile(counts: Sequence[float], q: float) -> float:
    """The ``q``-th percentile (milliseconds) of values counted in the histogram's buckets,
    interpolated linearly inside its bucket (as Prometheus' ``histogram_quantile``)."""
    total = sum(counts)
    if not total:
        return float("nan")
    rank, seen, lower = total * q / 100, 0.0, 0.0
    for bound, count in zip((*BUCKETS, float("inf")), counts, strict=True):
        if seen + count >= rank and count:
            if bound == float("inf"):
                return lower * 1000
            return (lower + (bound - lower) * (rank - seen) / count) * 1000
        seen += count
        lower = bound
    return lower * 1000


@contextmanager
def servers(store: str, directory: Path) -> Iterator[list[Process]]:
    """One service (``python -m service``) on the memory store, or a redis-server and two
    replicas on it; each as the container runs it behind its proxy (docker/docker-compose.yml's
    HTTP parser)."""
    with ExitStack() as stack:
        url, count = "memory://", 1
        if store == "redis":
            binary = shutil.which("redis-server")
            assert binary, "redis-server is not on PATH"
            port = free_port()
            args = [binary, "--port", str(port), "--bind", "127.0.0.1", "--save", "",
                    "--appendonly", "no", "--dir", str(directory)]  # fmt: skip
            redis = subprocess.Popen(args, stdout=subprocess.DEVNULL)
            stack.callback(redis.wait, 30)
            stack.callback(redis.kill)
            time.sleep(0.3)
            url, count = f"redis://127.0.0.1:{port}/0", 2
        env = {
            "PLANNER_STORE_URL": url,
            "PLANNER_POOL_SIZE": "1",
            "PLANNER_HTTP_PARSER": "httptools",
        }
        replicas = [stack.enter_context(service(env)) for _ in range(count)]
        for replica in replicas:
            replica.wait("/healthz", timeout=120)
        yield replicas


async def _bench(
    replicas: list[Process],
    scenarios: list[tuple[Scenario, int]],
    *,
    client: str = "aiohttp",
    skip: float = 0.0,
    pause: float = 0.0,
    spread_ms: float = 0.0,
) -> list[Outcome]:
    urls = [replica.url for replica in replicas]
    limits = httpx.Limits(max_connections=64)
    clients = [httpx.AsyncClient(base_url=u, timeout=60, limits=limits) for u in urls]
    steppers = [AiohttpStepper(u) for u in urls] if client == "aiohttp" else None
    # The client's own full garbage collections (over numpy, httpx, the scenarios: ~0.1 s
    # each) would stop it mid-tick and add their pause to the steps in flight.
    gc.collect()
    gc.freeze()
    try:
        out = []
        for n, (scenario, seed) in enumerate(scenarios):
            before = [await step_buckets(c) for c in clients]
            cpu = sum(replica.cpu_seconds() for replica in replicas)
            outcome = await run(
                clients, scenario, fleet=f"bench-{n}", seed=seed, steppers=steppers, skip=skip,
                pause=pause, spread_ms=spread_ms,
            )  # fmt: skip
            outcome.server_cpu_s = sum(replica.cpu_seconds() for replica in replicas) - cpu
            after = [await step_buckets(c) for c in clients]
            outcome.server_buckets = [
                sum(a[k] - b[k] for a, b in zip(after, before, strict=True))
                for k in range(len(after[0]))
            ]
            out.append(outcome)
        return out
    finally:
        gc.unfreeze()
        for c in clients:
            await c.aclose()
        for stepper in steppers or ():
            await stepper.aclose()


HEADER = (
    "| store | scenario | client | runs | collisions | deadlocks | arrived | errors "
    "| client p50 ms | client p99 ms | server p50 ms | server p99 ms | server ≤ 10 ms "
    "| client CPU µs/step | server CPU µs/step |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
)
"""The table :func:`_report` writes a row of."""


def _report(store: str, name: str, outcomes: list[Outcome], client: str) -> str:
    steps = [ms for o in outcomes for ms in o.step_ms]
    robots = sum(o.robots for o in outcomes)
    buckets = [sum(k) for k in zip(*(o.server_buckets for o in outcomes), strict=True)]
    served = sum(buckets)
    within = sum(buckets[: BUCKETS.index(0.01) + 1]) / served if served else float("nan")
    client_cpu = sum(o.client_cpu_s for o in outcomes) / max(len(steps), 1) * 1e6
    server_cpu = sum(o.server_cpu_s for o in outcomes) / max(len(steps), 1) * 1e6
    return (
        f"| {store} | {name} | {client} | {len(outcomes)} | "
        f"{sum(len(o.collisions) for o in outcomes)} | "
        f"{sum(o.deadlock for o in outcomes)} | {sum(o.arrived for o in outcomes)}/{robots} | "
        f"{sum(len(o.errors) for o in outcomes)} | {_percentile(steps, 50):.2f} | "
        f"{_percentile(steps, 99):.2f} | {bucket_percentile(buckets, 50):.2f} | "
        f"{bucket_percentile(buckets, 99):.2f} | {within:.1%} | {client_cpu:.0f} | "
        f"{server_cpu:.0f} |"
    )


def _scenarios(args: argparse.Namespace) -> dict[str, list[tuple[Scenario, int]]]:
    """The runs of each scenario asked for, by name (seeded: each seed its own run)."""
    depot = planner.read_ros_map(ros_maps() / "depot.yaml")
    every: dict[str, tuple[str, Callable[[int], Scenario], int]] = {
        "swap2": ("corridor swap x2", lambda s: corridor_scenario(1, s), args.seeds),
        "swap4": ("corridor swap x4", lambda s: corridor_scenario(2, s), args.seeds),
        "rooms": ("random rooms and corridors", random_corridor_scenario, args.rooms),
        "depot": (
            f"depot x{args.robots}, r = 0.3 m",
            lambda s: random_scenario(depot, args.robots, s, radius=0.3),
            args.random_seeds,
        ),
        "grid": (
            f"random-32-32-10 x{args.grid_robots}, r = 0",
            lambda s: grid_scenario(args.grid_robots, s),
            args.random_seeds,
        ),
    }
    return {every[k][0]: [(every[k][1](s), s) for s in range(every[k][2])] for k in args.scenarios}


def grid_scenario(count: int, seed: int) -> Scenario:
    """``count`` robots of radius 0 between random cells of the Moving AI map random-32-32-10
    (a plain grid: the roadmap is its free cells, 4-connected)."""
    grid = planner.read_map(ros_maps().parent / "mapf" / "random-32-32-10.map")
    robot_map = planner.grid_map(np.asarray(grid, dtype=np.int8), resolution=1.0)
    return random_scenario(robot_map, count, seed, radius=0.0)


async def _in_process(runs: list[tuple[Scenario, int]], skip: float, pause: float) -> list[Outcome]:
    """The runs through the app in this process (httpx's ASGI transport): the same steps and
    checks, no sockets (for many episodes)."""
    from service.config import Settings
    from service.main import create_app

    app = create_app(Settings(pool_size=1))
    out = []
    async with app.router.lifespan_context(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://s") as client:
            for n, (scenario, seed) in enumerate(runs):
                out.append(
                    await run([client], scenario, fleet=f"f{n}", seed=seed, skip=skip, pause=pause)
                )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--rooms", type=int, default=20, help="random rooms-and-corridor runs")
    parser.add_argument("--robots", type=int, default=16)
    parser.add_argument("--grid-robots", type=int, default=100)
    parser.add_argument("--random-seeds", type=int, default=3)
    parser.add_argument("--first-seed", type=int, default=0, help="the runs' seeds start here")
    parser.add_argument("--skip", type=float, default=0.2, help="chance a robot sits a tick out")
    parser.add_argument("--pause", type=float, default=0.02, help="chance a robot falls silent")
    parser.add_argument(
        "--spread", type=float, default=0.0, metavar="MS",
        help="each robot's step sent at a random moment within MS ms of its tick's start "
        "(0: all at once)",
    )  # fmt: skip
    parser.add_argument("--store", nargs="+", default=["memory", "redis"])
    parser.add_argument(
        "--scenarios", nargs="+", default=["swap2", "swap4", "rooms", "depot", "grid"]
    )
    parser.add_argument(
        "--client", nargs="+", choices=["httpx", "aiohttp"], default=["aiohttp"],
        help="who sends the steps: httpx, or aiohttp (AiohttpStepper; the default)",
    )  # fmt: skip
    parser.add_argument(
        "--in-process", action="store_true", help="the runs through the app in this process"
    )
    args = parser.parse_args()
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    sets = _scenarios(args)
    if args.in_process:
        print(HEADER)
        for name, runs in sets.items():
            outcomes = asyncio.run(_in_process(runs, args.skip, args.pause))
            print(_report("in-process", name, outcomes, "httpx ASGI"), flush=True)
            for o in outcomes:
                for line in (o.collisions + o.errors)[:3]:
                    print("  ", line, file=sys.stderr)
        return
    print(HEADER)
    for store in args.store:
        with tempfile.TemporaryDirectory() as tmp, servers(store, Path(tmp)) as replicas:
            for (name, scenarios), client in itertools.product(sets.items(), args.client):
                # On uvloop, as the servers run: less of the client's CPU in each round trip.
                run_ = _bench(
                    replicas, scenarios, client=client, skip=args.skip, pause=args.pause,
                    spread_ms=args.spread,
                )  # fmt: skip
                outcomes = uvloop.run(run_)
                print(_report(store, name, outcomes, client), flush=True)
                print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
                for o in outcomes:
                    for line in (o.collisions + o.errors)[:3]:
                        print("  ", line, file=sys.stderr)


if __name__ == "__main__":
    main()

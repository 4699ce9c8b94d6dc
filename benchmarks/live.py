"""The live layer (docs/live.md) measured: robots on ``depot`` seeing with simulated lasers.

1. **Driving.** A 0.22 m robot drives across ``depot`` (``python -m service`` over HTTP, the
   memory store), each step a 720-ray scan ray-cast from the map plus boxes that cross its
   route (``live_world.py``), reported with its pose; it drives 0.1 m along the poses each
   step answers. Counted: steps that answer short (poses under ``horizon_m`` and not to the
   goal), steps that wait, detours (``replanned`` steps: the route's growth in meters), the
   closest the robot came to a box, and the meters driven against the plan's.
2. **A scan's cost.** One 1,080-ray scan (range 12 m) on ``depot``: the body parsed
   (``ObservationCreate``), the rays traced (``planner.trace_scan``) and the store updated
   (memory, and Redis when ``redis-server`` is installed: one script call), in-process,
   median and p99 over 300 scans; and ``POST /maps/{id}/observations`` over HTTP.
3. **A second robot.** Robot B's route straight across the hall; robot A, standing elsewhere,
   reports a scan of a pallet on B's way: B's next step goes around it.
4. **10 scans a second.** A thread posts 1,080-ray scans at 10 Hz for 10 s while another
   reads ``/healthz`` every 50 ms: the slowest ``/healthz``.

    .venv/bin/python benchmarks/live.py [--steps 400]
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import math
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import orjson
from common import ROOT, free_port, ros_maps, service
from live_world import Box, cast

sys.path.insert(0, str(ROOT))

import planner
from schemas import ObservationCreate
from service.stores import MemoryStore, RedisStore, Store
from service.stores.live import Seen

RADIUS = 0.22
START, GOAL = (3.0, 7.5), (27.0, 7.5)
SPEED_STEP = 0.1  # meters driven a step (0.5 m/s at 5 steps a second)


def upload(client: httpx.Client, folder: Path) -> str:
    files = {
        "yaml": ("depot.yaml", (folder / "depot.yaml").read_bytes()),
        "image": ("depot.pgm", (folder / "depot.pgm").read_bytes()),
    }
    r = client.post("/maps", files=files)
    r.raise_for_status()
    return str(r.json()["map_id"])


def along(poses: list[dict[str, float]], distance: float) -> tuple[float, float, float]:
    """The point ``distance`` meters along the poses' polyline (its last pose beyond)."""
    for a, b in itertools.pairwise(poses):
        step = math.hypot(b["x"] - a["x"], b["y"] - a["y"])
        if step >= distance and step > 0:
            t = distance / step
            return a["x"] + t * (b["x"] - a["x"]), a["y"] + t * (b["y"] - a["y"]), b["yaw"]
        distance -= step
    last = poses[-1]
    return last["x"], last["y"], last["yaw"]


def length(poses: list[dict[str, float]]) -> float:
    return sum(math.hypot(b["x"] - a["x"], b["y"] - a["y"]) for a, b in itertools.pairwise(poses))


def boxes_at(k: int) -> list[Box]:
    """Pallets crossing the route: each slides 0.02 m a step between y 5.5 and 9.5."""
    out = []
    for x, phase in ((9.0, 0), (15.0, 60), (21.0, 130)):
        y = 5.5 + 4.0 * abs(((k + phase) * 0.005) % 2 - 1)
        out.append(Box(x - 0.3, y - 0.3, x + 0.3, y + 0.3))
    return out


def box_distance(x: float, y: float, boxes: list[Box]) -> float:
    return min(math.hypot(max(b.x0 - x, 0, x - b.x1), max(b.y0 - y, 0, y - b.y1)) for b in boxes)


def drive(client: httpx.Client, map_id: str, robot_map: planner.RobotMap, steps: int) -> None:
    blocked = robot_map.blocked()
    body = {
        "map_id": map_id,
        "start": dict(zip("xy", START, strict=True)),
        "goal": dict(zip("xy", GOAL, strict=True)),
    }
    r = client.post("/plan", json={**body, "robot_radius": RADIUS})
    r.raise_for_status()
    plan = r.json()
    planned = plan["preview"]["length_poses_m"]
    plan_id = plan["plan_id"]
    x, y, yaw = START[0], START[1], 0.0
    short = waiting = replanned = 0
    detours: list[float] = []
    closest = math.inf
    driven = 0.0
    previous_remaining = None
    times = []
    k = 0
    status = ""
    moved = 0.0  # since the previous step
    for k in range(steps):
        boxes = boxes_at(k)
        scan = cast(blocked, robot_map.frame, (x, y, yaw), boxes, rays=720, range_max=8.0)
        step = {"seq": k, "position": {"x": x, "y": y, "yaw": yaw}, "scan": scan}
        t0 = time.perf_counter()
        r = client.post(f"/plan/{plan_id}/step", json=step)
        times.append((time.perf_counter() - t0) * 1e3)
        r.raise_for_status()
        answer = r.json()
        status = answer["status"]
        if status == "arrived":
            break
        poses = answer["poses"]
        ahead = length(poses)
        to_goal = math.hypot(poses[-1]["x"] - GOAL[0], poses[-1]["y"] - GOAL[1]) < 0.1
        if status == "waiting":
            waiting += 1
        elif ahead < 2.0 - 0.05 and not to_goal:
            short += 1
        remaining = answer["remaining_m"]
        replanned += status == "replanned"
        if previous_remaining is not None and remaining is not None:
            detours.append(remaining - (previous_remaining - moved))
        previous_remaining = remaining
        moved = 0.0
        if len(poses) > 1:
            nx, ny, yaw = along(poses, SPEED_STEP)
            moved = math.hypot(nx - x, ny - y)
            driven += moved
            x, y = nx, ny
        closest = min(closest, box_distance(x, y, boxes_at(k + 1)) - RADIUS)
    grown = [d for d in detours if d > 0.05]
    print(
        f"driving: {k + 1} steps to '{status}', {driven:.1f} m driven for a {planned:.1f} m plan; "
        f"{short} short ({100 * short / (k + 1):.1f} %), {waiting} waiting "
        f"({100 * waiting / (k + 1):.1f} %), {replanned} replanned, {len(grown)} steps whose "
        f"route grew by > 5 cm (median {statistics.median(grown) if grown else 0:.2f} m, "
        f"max {max(grown, default=0):.2f} m); closest to a box {closest:.2f} m beyond the "
        f"radius; step over HTTP with a 720-ray scan median {statistics.median(times):.1f} ms, "
        f"p99 {np.percentile(times, 99):.1f} ms"
    )


PALLETS = [Box(x, y, x + 0.6, y + 0.6) for x, y in ((6, 4), (10, 10), (14, 6), (18, 9), (22, 5))]
"""Pallets standing in the hall while the scans' cost is measured (scans of the same things
from many poses: the live layer holds a few hundred marks, as a warehouse's would)."""


def scan_body(robot_map: planner.RobotMap, rng: np.random.Generator) -> tuple[bytes, Any]:
    """A 1,080-ray, 12 m scan from a free point of the hall, among the pallets."""
    blocked = robot_map.blocked()
    while True:
        x, y = rng.uniform(2, 28), rng.uniform(2, 13)
        r, c = robot_map.frame.cells([[x, y]])[0]
        clear = not blocked[max(r - 6, 0) : r + 7, max(c - 6, 0) : c + 7].any()
        if clear and box_distance(x, y, PALLETS) > 0.5:
            break
    pose = (float(x), float(y), float(rng.uniform(-math.pi, math.pi)))
    scan = cast(blocked, robot_map.frame, pose, PALLETS, rays=1080, range_max=12.0)
    body = {"scan": scan, "scan_pose": {"x": pose[0], "y": pose[1], "yaw": pose[2]}}
    return orjson.dumps(body), pose


def scan_cost(robot_map: planner.RobotMap, bodies: list[bytes], store: Store, name: str) -> None:
    blocked = robot_map.blocked()
    frame = robot_map.frame
    parse, trace, update = [], [], []

    async def run() -> None:
        for raw in bodies:
            t0 = time.perf_counter()
            body = ObservationCreate.model_validate_json(raw)
            t1 = time.perf_counter()
            scan = body.scan
            laser = planner.LaserScan(
                scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max,
                np.array(scan.ranges, dtype=np.float64),
            )  # fmt: skip
            pose = body.scan_pose
            traced = planner.trace_scan(frame, blocked, laser, (pose.x, pose.y, pose.yaw))
            t2 = time.perf_counter()
            await store.observe("depot", Seen(traced, frame.shape[1], 5.0))
            t3 = time.perf_counter()
            parse.append((t1 - t0) * 1e3)
            trace.append((t2 - t1) * 1e3)
            update.append((t3 - t2) * 1e3)

    asyncio.run(run())
    total = [a + b + c for a, b, c in zip(parse, trace, update, strict=True)]
    print(
        f"a 1,080-ray scan, in-process, {name} store: parse median {statistics.median(parse):.2f}"
        f" ms, trace {statistics.median(trace):.2f} ms, store {statistics.median(update):.2f} ms;"
        f" all median {statistics.median(total):.2f} ms, p99 {np.percentile(total, 99):.2f} ms"
    )


def second_robot(client: httpx.Client, map_id: str, robot_map: planner.RobotMap) -> None:
    pallet = Box(14.7, 7.1, 15.3, 7.9)  # on B's straight way across the hall, 1.7 m ahead
    body = {"map_id": map_id, "start": {"x": 13.0, "y": 7.5}, "goal": {"x": 19.0, "y": 7.5}}
    plan_id = client.post("/plan", json={**body, "robot_radius": RADIUS}).json()["plan_id"]
    before = client.post(f"/plan/{plan_id}/step", json={"seq": 0}).json()
    pose = (12.2, 9.6, 0.0)  # robot A, north-west of the pallet: it sees the side B comes to
    scan = cast(robot_map.blocked(), robot_map.frame, pose, [pallet], rays=1080, range_max=12.0)
    seen = {"scan": scan, "scan_pose": dict(zip(("x", "y", "yaw"), pose, strict=True))}
    marks = client.post(f"/maps/{map_id}/observations", json=seen).json()["marks"]
    points = np.array(client.get(f"/maps/{map_id}/live").json()["points"]).reshape(-1, 2)
    after = client.post(f"/plan/{plan_id}/step", json={"seq": 1}).json()

    def shape(poses: list[dict[str, float]]) -> str:
        xy = np.array([[p["x"], p["y"]] for p in poses])
        off = float(np.abs(xy[:, 1] - 7.5).max())
        near = float(np.min(np.hypot(*(xy[:, None, :] - points[None, :, :]).transpose(2, 0, 1))))
        return (
            f"{length(poses):.2f} m of poses, at most {off:.2f} m off the straight line, "
            f"{near:.2f} m from the nearest mark"
        )

    print(
        f"second robot: before A's scan '{before['status']}', {shape(before['poses'])}; A's scan "
        f"marked {marks} cells; B's next step '{after['status']}', {shape(after['poses'])} "
        f"(B's radius {RADIUS} m; remaining_m {before['remaining_m']:.2f} -> "
        f"{after['remaining_m']:.2f})"
    )


def healthz_under_scans(url: str, map_id: str, bodies: list[bytes]) -> None:
    stop = threading.Event()
    worst: list[float] = []

    def scans() -> None:
        with httpx.Client(base_url=url, trust_env=False, timeout=10) as c:
            i = 0
            while not stop.is_set():
                t0 = time.perf_counter()
                c.post(f"/maps/{map_id}/observations", content=bodies[i % len(bodies)],
                       headers={"content-type": "application/json"})  # fmt: skip
                i += 1
                time.sleep(max(0.0, 0.1 - (time.perf_counter() - t0)))

    thread = threading.Thread(target=scans)
    thread.start()
    with httpx.Client(base_url=url, trust_env=False, timeout=10) as c:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            t0 = time.perf_counter()
            c.get("/healthz")
            worst.append((time.perf_counter() - t0) * 1e3)
            time.sleep(0.05)
    stop.set()
    thread.join()
    print(
        f"10 scans a second for 10 s: /healthz median {statistics.median(worst):.1f} ms, "
        f"max {max(worst):.1f} ms ({len(worst)} reads)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=400)
    args = parser.parse_args()
    folder = ros_maps()
    robot_map = planner.read_ros_map(folder / "depot.yaml")
    rng = np.random.default_rng(7)
    bodies = [scan_body(robot_map, rng)[0] for _ in range(300)]
    scan_cost(robot_map, bodies, MemoryStore(ttl_seconds=60), "memory")
    port = free_port()
    redis = subprocess.Popen(
        ["redis-server", "--port", str(port), "--save", "", "--appendonly", "no"],
        stdout=subprocess.DEVNULL,
    )
    try:
        time.sleep(0.5)
        store = RedisStore(f"redis://127.0.0.1:{port}/0", ttl_seconds=60)
        scan_cost(robot_map, bodies, store, "redis")
    finally:
        redis.terminate()
        redis.wait()
    with service({"PLANNER_POOL_SIZE": "2"}) as server:
        server.wait("/healthz")
        with httpx.Client(base_url=server.url, trust_env=False, timeout=60) as client:
            map_id = upload(client, folder)
            times = []
            for raw in bodies[:100]:
                t0 = time.perf_counter()
                r = client.post(f"/maps/{map_id}/observations", content=raw,
                                headers={"content-type": "application/json"})  # fmt: skip
                r.raise_for_status()
                times.append((time.perf_counter() - t0) * 1e3)
            print(
                f"POST /maps/{{id}}/observations over HTTP, 1,080 rays: median "
                f"{statistics.median(times):.2f} ms, p99 {np.percentile(times, 99):.2f} ms"
            )
            second_robot(client, map_id, robot_map)
            healthz_under_scans(server.url, map_id, bodies)
            # The driving robot on a layer of its own: the marks above have lapsed by now.
            time.sleep(5.5)
            drive(client, map_id, robot_map, args.steps)


if __name__ == "__main__":
    main()

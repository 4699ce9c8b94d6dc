"""Narrow passages on the shared ROS maps, side by side in one run: ``find_passages`` against
the analysis a plan needs (``analyse_map``), its medial axis against scikit-image's, then
``GET /maps/{id}/passages`` in-process (the app, its pool and cache, over ASGI) cold and cached,
and what the passages add to a robot map's first plan::

    .venv/bin/python benchmarks/passages.py             # depot, the largest shared ROS map
    .venv/bin/python benchmarks/passages.py --map tb3_sandbox --repeats 9
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import subprocess
import sys
import time
from collections.abc import Callable

import httpx
import numpy as np
from common import ROOT, ros_maps
from skimage.morphology import medial_axis

sys.path.insert(0, str(ROOT))

import planner
from planner.analysis.medial import medial_axis as planner_medial_axis
from service.config import Settings
from service.main import create_app


def cpu() -> str:
    text = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    model = next(
        (ln.split(":", 1)[1].strip() for ln in text.splitlines() if "Model name" in ln), "?"
    )
    count = next(
        (ln.split(":", 1)[1].strip() for ln in text.splitlines() if ln.startswith("CPU(s)")), "?"
    )
    return f"{model}, {count} vCPUs"


def ms(fn: Callable[[], object]) -> float:
    t = time.perf_counter()
    fn()
    return (time.perf_counter() - t) * 1e3


def side_by_side(robot_map: planner.RobotMap, radius: float, repeats: int) -> None:
    params = planner.resolve_params(robot_radius=radius)
    cs = planner.configuration_space(robot_map, robot_radius=radius)
    free = cs.blocked == 0
    padded = np.pad(free, 1)
    cases: dict[str, Callable[[], object]] = {
        "find_passages": lambda: planner.find_passages(robot_map, radius),
        "analyse_map": lambda: planner.analyse_map(robot_map, params),
        "its medial axis (numba)": lambda: planner_medial_axis(free, cs.distance),
        "scikit-image medial_axis, same cells": lambda: medial_axis(padded, rng=0),  # type: ignore[no-untyped-call]
    }
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(repeats):  # alternated: the machine's load falls on all alike
        for name, fn in cases.items():
            times[name].append(ms(fn))
    base = statistics.median(times["analyse_map"])
    print("\n| in-process | median ms | min ms | against analyse_map |\n|---|---|---|---|")
    for name, values in times.items():
        med = statistics.median(values)
        print(f"| {name} | {med:.1f} | {min(values):.1f} | {med / base:.2f} x |")


async def over_asgi(robot_map: planner.RobotMap, radius: float, repeats: int) -> None:
    app = create_app(Settings(pool_size=2, max_map_cells=1 << 24))
    message = robot_map.to_occupancy_grid()
    async with app.router.lifespan_context(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://bench") as client:
            map_id = (await client.post("/maps", json={"occupancy_grid": message})).json()["map_id"]
            url = f"/maps/{map_id}/passages"
            cold, warm = [], []
            for i in range(repeats):  # a new max_width each time: computed, then cached
                query = {"robot_radius": radius, "max_width": 2 * radius + 0.3 + i * 1e-3}
                t = time.perf_counter()
                r = await client.get(url, params=query)
                cold.append((time.perf_counter() - t) * 1e3)
                assert r.status_code == 200, r.text
                t = time.perf_counter()
                await client.get(url, params=query)
                warm.append((time.perf_counter() - t) * 1e3)
            # Ends with room to spare: the radius grows by 1 mm a repeat.
            cells = planner.configuration_space(robot_map, robot_radius=radius + 0.05).traversable
            free = np.argwhere(cells == 1)
            far = free[np.argmax(np.abs(free - free[0]).sum(axis=1))]
            first, again = [], []
            for i in range(repeats):  # a new radius each time: analysis and passages both cold
                body = {"map_id": map_id, "start": free[0].tolist(), "goal": far.tolist(),
                        "robot_radius": radius + i * 1e-3}  # fmt: skip
                t = time.perf_counter()
                r = await client.post("/plan", json=body)
                first.append((time.perf_counter() - t) * 1e3)
                assert r.status_code == 201, r.text
                t = time.perf_counter()
                await client.post("/plan", json=body)
                again.append((time.perf_counter() - t) * 1e3)
    print("\n| over ASGI (in-process app, pool of 2) | median ms | min ms |\n|---|---|---|")
    for name, values in (
        ("GET passages, computed (cold)", cold),
        ("GET passages, cached", warm),
        ("POST /plan, new radius (analysis + passages cold)", first),
        ("POST /plan, same again (both cached)", again),
    ):
        print(f"| {name} | {statistics.median(values):.1f} | {min(values):.1f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--map", default="depot", help="a shared ROS map's name")
    parser.add_argument("--radius", type=float, default=0.22, help="the robot's radius, meters")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    folder = ros_maps()
    robot_map = planner.read_ros_map(folder / f"{args.map}.yaml")
    planner.warm_up()
    found = planner.find_passages(robot_map, args.radius)
    H, W = robot_map.shape
    print(f"{args.map}: {H} x {W} cells, robot radius {args.radius} m, {len(found)} passages")
    print(f"CPU: {cpu()}")
    side_by_side(robot_map, args.radius, args.repeats)
    asyncio.run(over_asgi(robot_map, args.radius, args.repeats))


if __name__ == "__main__":
    main()

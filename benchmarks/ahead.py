"""The path ahead goes around (docs/api.md, "Stepping"): steps with a circle just ahead.

On each shared ROS map (beside the repository), robots of radius 0.22 m on a few far-apart
routes (a plan each, as the service makes it, warmed by a drive along its route); at points
along each route a step reports the robot there (off its cell's center, heading along the
route) with a 0.3 m circle on the route 0.6-1.6 m ahead. Counted are the cases with a way round
(a whole-map detour from the robot's cell exists): how many answers have poses of at least
``horizon_m`` (or to the goal) that keep the circle plus the radius clear, how many wait, and
the step's time: in-process (``Session.step``, wall and the thread's CPU time) and, with
``--http``, over HTTP (each step's server time from the growth of the server's request-duration
histogram's sum, the same points without the circle beside it, the server's CPU a step, and the
client's round trip)::

    .venv/bin/python benchmarks/ahead.py [--routes 4] [--every 25] [--http]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

import planner

NAMES = ("depot", "tb3_sandbox", "smoothers_world")
ROBOT_RADIUS = 0.22
CIRCLE_RADIUS = 0.3


@dataclass(frozen=True, slots=True)
class Case:
    """One step to ask: the robot's point and heading, and the circle ahead of it."""

    cell: tuple[int, int]
    position: dict[str, float]
    circle: dict[str, float]
    obstacles: list[list[int]]


@dataclass(slots=True)
class Tally:
    cases: int = 0
    good: int = 0
    waiting: int = 0
    short: list[float] = field(default_factory=list)
    times_ms: list[float] = field(default_factory=list)
    cpu_ms: list[float] = field(default_factory=list)


def routes(
    robot_map: planner.RobotMap, analysis: planner.Analysis, count: int, seed: int
) -> list[tuple[list[int], list[int]]]:
    """``count`` start and goal cells far apart: the farthest of a few random goals."""
    cells = np.argwhere(analysis.passable() == 1)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        start = cells[rng.integers(len(cells))]
        goals = cells[rng.choice(len(cells), size=64)]
        goal = goals[np.argmax(np.abs(goals - start).sum(axis=1))]
        out.append((start.tolist(), goal.tolist()))
    return out


def cases(
    plan: planner.Plan, robot_map: planner.RobotMap, every: int, rng: np.random.Generator
) -> list[Case]:
    """Every ``every`` cells along the plan's path: a circle 0.6-1.6 m ahead on the path, kept
    when a way round exists."""
    frame = robot_map.frame
    res = frame.resolution
    path = plan.path
    xy = frame.centers(path.tolist())
    along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))
    out = []
    for i in range(0, len(path) - 1, every):
        ahead = along[i] + rng.uniform(0.6, 1.6)
        j = int(np.searchsorted(along, ahead))
        if j >= len(path) - 1:
            break
        cx, cy = xy[j]
        circle = {"x": float(cx), "y": float(cy), "radius": CIRCLE_RADIUS}
        cells = planner.circle_cells(robot_map, [circle], robot_radius=ROBOT_RADIUS)
        cell = (int(path[i, 0]), int(path[i, 1]))
        if len(planner.detour(plan, cell, cells)) == 0:
            continue  # no way round
        x, y = xy[i] + rng.uniform(-0.3, 0.3, size=2) * res
        dx, dy = xy[min(i + 4, len(path) - 1)] - xy[i]
        position = {"x": float(x), "y": float(y), "yaw": math.atan2(dy, dx)}
        out.append(Case(cell, position, circle, cells.tolist()))
    return out


def judge(
    end: tuple[float, float], horizon: float, case: Case, poses: Any, status: str, tally: Tally
) -> None:
    """Counts one answer: good when its poses reach ``horizon_m`` (or the goal) and every
    segment keeps more than the circle's radius plus the robot's from its center."""
    P = np.array(poses, dtype=np.float64)[:, :2]
    length = float(np.hypot(*np.diff(P, axis=0).T).sum()) if len(P) > 1 else 0.0
    to_goal = bool(np.hypot(*(P[-1] - np.array(end))) < 1e-6)
    c = np.array([case.circle["x"], case.circle["y"]])
    a, b = P[:-1], P[1:]
    d = b - a
    t = np.clip(((c - a) * d).sum(axis=1) / np.maximum((d * d).sum(axis=1), 1e-30), 0.0, 1.0)
    near = float(np.hypot(*(a + t[:, None] * d - c).T).min()) if len(P) > 1 else math.inf
    clear = near > CIRCLE_RADIUS + ROBOT_RADIUS
    long_enough = length >= horizon - 1e-9 or to_goal
    tally.cases += 1
    tally.good += long_enough and clear
    tally.waiting += status == "waiting"
    if not long_enough:
        tally.short.append(length)


def in_process(plan: planner.Plan, todo: list[Case], tally: Tally) -> None:
    for case in todo:
        session = planner.Session(plan)
        t0, c0 = time.perf_counter(), time.thread_time()
        step = session.step(case.obstacles, position=case.position, seq=0)
        tally.cpu_ms.append((time.thread_time() - c0) * 1e3)
        tally.times_ms.append((time.perf_counter() - t0) * 1e3)
        end = plan.goal_used if plan.goal_used is not None else plan.goal_point
        assert end is not None
        judge(end, plan.params.horizon_m, case, step.poses, step.status, tally)


def over_http(work: list[tuple[str, list[int], list[int], list[Case]]]) -> None:
    """The same steps over HTTP, on one server: a plan a route, warmed by a drive along it, then a
    step a case (the robot reported at the case's point) with the circle, then at the same
    point without it. A step's server time is what its request added to the server's
    request-duration histogram's sum (read from ``/metrics`` around it); beside it, the
    client's round trip."""
    import httpx
    from common import service

    folder = ros_maps()
    tally = Tally()
    times: dict[str, list[float]] = {"circle": [], "none": [], "trip": []}
    cpu: dict[str, float] = {"circle": 0.0, "none": 0.0}
    with service({"PLANNER_LOG_LEVEL": "warning"}) as server:
        server.wait("/healthz")
        with httpx.Client(base_url=server.url, timeout=120, trust_env=False) as client:

            def step(plan_id: str, body: dict[str, Any], kind: str) -> dict[str, Any]:
                before = _step_seconds(client.get("/metrics").text)
                c0, t0 = server.cpu_seconds(), time.perf_counter()
                r = client.post(f"/plan/{plan_id}/step", json=body)
                trip = (time.perf_counter() - t0) * 1e3
                cpu[kind] += server.cpu_seconds() - c0
                r.raise_for_status()
                times[kind].append(1e3 * (_step_seconds(client.get("/metrics").text) - before))
                if kind == "circle":
                    times["trip"].append(trip)
                answer: dict[str, Any] = r.json()
                return answer

            maps: dict[str, str] = {}
            for name, start, goal, todo in work:
                if name not in maps:
                    files = {
                        "yaml": ("m.yaml", (folder / f"{name}.yaml").read_bytes()),
                        "image": ("m.pgm", (folder / f"{name}.pgm").read_bytes()),
                    }
                    r = client.post("/maps", files=files)
                    r.raise_for_status()
                    maps[name] = r.json()["map_id"]
                body = {"map_id": maps[name], "start": start, "goal": goal,
                        "params": {"robot_radius": ROBOT_RADIUS}}  # fmt: skip
                r = client.post("/plan", json=body)
                r.raise_for_status()
                answer = r.json()
                plan_id = answer["plan_id"]
                last = answer["preview"]["poses"][-1]
                end = (float(last["x"]), float(last["y"]))
                seq = 0
                while True:  # warm: the robot drives its route once
                    r = client.post(f"/plan/{plan_id}/step", json={"seq": seq})
                    r.raise_for_status()
                    seq += 1
                    if r.json()["status"] == "arrived":
                        break
                for case in todo:
                    at = {"seq": seq, "position": case.position}
                    got = step(plan_id, {**at, "dynamic_obstacles": [case.circle]}, "circle")
                    poses = [[p["x"], p["y"]] for p in got["poses"]]
                    judge(end, 2.0, case, poses, got["status"], tally)
                    step(plan_id, {**at, "seq": seq + 1}, "none")
                    seq += 2
    share = 100.0 * tally.good / max(tally.cases, 1)
    print("\nOver HTTP (one server; a step reporting the robot's point, warm plans; "
          f"load average {os.getloadavg()[0]:.1f}):\n")  # fmt: skip
    print("| steps | poses >= horizon (or to goal) and clear | waiting "
          "| server ms with the circle (median / p99) | without it (same points) "
          "| server CPU ms a step, with / without (mean) "
          "| round trip ms with it (median / p99) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    c, n, t = times["circle"], times["none"], times["trip"]
    print(
        f"| {tally.cases} | {tally.good} ({share:.1f} %) | {tally.waiting} | "
        f"{percentile(c, 50):.2f} / {percentile(c, 99):.2f} | "
        f"{percentile(n, 50):.2f} / {percentile(n, 99):.2f} | "
        f"{1e3 * cpu['circle'] / max(len(c), 1):.2f} / {1e3 * cpu['none'] / max(len(n), 1):.2f} | "
        f"{percentile(t, 50):.2f} / {percentile(t, 99):.2f} |"
    )


def _step_seconds(text: str) -> float:
    """The seconds the step route's requests took in all, from the service's Prometheus text."""
    total = 0.0
    for line in text.splitlines():
        if line.startswith("planner_http_request_duration_seconds_sum") and "/step" in line:
            total += float(line.rsplit(" ", 1)[1])
    return total


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else math.nan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--routes", type=int, default=4, help="routes a map")
    parser.add_argument("--every", type=int, default=25, help="cells between cases on a route")
    parser.add_argument("--http", action="store_true", help="over HTTP too")
    args = parser.parse_args()
    folder = ros_maps()
    params = {"robot_radius": ROBOT_RADIUS}
    total = Tally()
    rows = []
    work: list[tuple[str, list[int], list[int], list[Case]]] = []
    handed_over = 0
    for name in NAMES:
        robot_map = planner.read_ros_map(folder / f"{name}.yaml")
        analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", **params))
        tally = Tally()
        rng = np.random.default_rng(1)
        for start, goal in routes(robot_map, analysis, args.routes, 0):
            # The cases from a whole-map wave's plan (its detours say whether a way round
            # exists); the steps on the plan a service makes (a resumable wave), warm: a robot
            # drove its route once.
            whole = planner.plan(
                robot_map, start, goal, analysis=analysis, robot_radius=ROBOT_RADIUS, whole=True
            )
            todo = cases(whole, robot_map, args.every, rng)
            plan = planner.plan(
                robot_map, start, goal, analysis=analysis, robot_radius=ROBOT_RADIUS
            )
            drive = planner.Session(plan)
            while drive.step([]).status != "arrived":
                pass
            in_process(plan, todo[:3], Tally())  # compiled
            in_process(plan, todo, tally)
            handed_over += (
                not isinstance(plan.wave, planner.ResumableWave) or not plan.wave.resumable
            )
            work.append((name, start, goal, todo))
        rows.append((name, tally))
        total.cases += tally.cases
        total.good += tally.good
        total.waiting += tally.waiting
        total.times_ms += tally.times_ms
        total.cpu_ms += tally.cpu_ms
    load = os.getloadavg()[0]
    print(
        "In-process (`Session.step`, a step reporting the robot's point, with the circle; "
        f"waves handed over to the whole-map one: {handed_over} of {len(work)}), "
        f"AMD EPYC 2 vCPU, load average {load:.1f}; wall time, and the thread's CPU time):\n"
    )
    print("| map | steps | poses >= horizon (or to goal) and clear | waiting "
          "| wall ms median / p99 | CPU ms median / p99 |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for name, t in [*rows, ("all", total)]:
        share = 100.0 * t.good / max(t.cases, 1)
        print(
            f"| {name} | {t.cases} | {t.good} ({share:.1f} %) | {t.waiting} | "
            f"{percentile(t.times_ms, 50):.2f} / {percentile(t.times_ms, 99):.2f} | "
            f"{percentile(t.cpu_ms, 50):.2f} / {percentile(t.cpu_ms, 99):.2f} |"
        )
    if args.http:
        over_http(work)


if __name__ == "__main__":
    main()

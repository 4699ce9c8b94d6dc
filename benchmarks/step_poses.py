"""What the path ahead (a step's ``poses`` and ``remaining_m``) adds to a step, in-process.

On each shared ROS map (beside the repository) with a robot radius of 0.22 m, a far-apart
start and goal: a session steps from start to goal reporting an off-center point and a heading
each step, with two circles of 0.3 m on its way ahead every other step, once with the path
ahead (``Session(plan)``) and once without (``Session(plan, poses=False)``), the same requests
both times. Prints the median and p99 µs of a step's ``Session.step`` call each way::

    .venv/bin/python benchmarks/step_poses.py [--horizon 2.0] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from typing import Any

import numpy as np
from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

import planner

NAMES = ("depot", "tb3_sandbox", "smoothers_world")


def requests(plan: planner.Plan, robot_map: planner.RobotMap, seed: int) -> list[dict[str, Any]]:
    """The steps' bodies along the plan's path: a point off each cell's center, a heading, and
    every other step two circles a few meters ahead (as cells, with the robot's radius)."""
    rng = np.random.default_rng(seed)
    frame = robot_map.frame
    res = frame.resolution
    path = plan.path
    out = []
    for i, cell in enumerate(path[:-1].tolist()):
        x, y = frame.centers([cell])[0] + rng.uniform(-0.3, 0.3, size=2) * res
        obstacles: list[list[int]] = []
        if i % 2:
            circles = []
            for ahead in (int(rng.integers(20, 60)), int(rng.integers(60, 120))):
                cx, cy = frame.centers([path[min(i + ahead, len(path) - 1)]])[0]
                circles.append({"x": float(cx) + 0.4, "y": float(cy), "radius": 0.3})
            obstacles = planner.circle_cells(robot_map, circles, robot_radius=0.22).tolist()
        position = {"x": float(x), "y": float(y), "yaw": float(rng.uniform(-3, 3))}
        out.append({"obstacles": obstacles, "position": position})
    return out


def run(plan: planner.Plan, bodies: list[dict[str, Any]], poses: bool) -> list[float]:
    session = planner.Session(plan, poses=poses)
    times = []
    for seq, body in enumerate(bodies):
        t0 = time.perf_counter()
        session.step(body["obstacles"], position=body["position"], seq=seq)
        times.append((time.perf_counter() - t0) * 1e6)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--horizon", type=float, default=2.0)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    folder = ros_maps()
    print("| map | cells | resolution | steps | µs a step without poses (median / p99) "
          "| with poses | added (median) | poses a step (median) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for name in NAMES:
        robot_map = planner.read_ros_map(folder / f"{name}.yaml")
        params = {"robot_radius": 0.22, "horizon_m": args.horizon}
        analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", **params))
        cells = np.argwhere(analysis.passable() == 1)
        rng = np.random.default_rng(0)
        # Far apart: the farthest of a few random goals from a random start.
        start = cells[rng.integers(len(cells))]
        goals = cells[rng.choice(len(cells), size=64)]
        goal = goals[np.argmax(np.abs(goals - start).sum(axis=1))]
        plan = planner.plan(
            robot_map, start.tolist(), goal.tolist(), analysis=analysis, whole=True, **params
        )
        bodies = requests(plan, robot_map, 0)
        run(plan, bodies[:50], True)  # compiled, warm
        without, with_ = [], []
        for _ in range(args.rounds):
            without += run(plan, bodies, False)
            with_ += run(plan, bodies, True)
        session = planner.Session(plan)
        counts = [len(session.step(b["obstacles"], position=b["position"]).poses) for b in bodies]
        m0, m1 = statistics.median(without), statistics.median(with_)
        p0, p1 = np.percentile(without, 99), np.percentile(with_, 99)
        print(
            f"| {name} | {analysis.shape[0]} x {analysis.shape[1]} | "
            f"{robot_map.resolution:g} m | {len(bodies)} | {m0:.0f} / {p0:.0f} | "
            f"{m1:.0f} / {p1:.0f} | {m1 - m0:.0f} | {statistics.median(counts):.0f} |"
        )


if __name__ == "__main__":
    main()

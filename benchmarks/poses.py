"""Poses on every shared ROS map: how often every rule holds, how much shorter and straighter the
poses are than the grid path, and what the smoothing adds to a warm plan's time.

For each shared ROS map (beside the repository), a robot radius (0.22 m; 0.1 m on a map under
2 m a side) and seeded far-apart start/goal pairs (points off their cells' centers, a goal
yaw on every other one), it plans with ``wide`` on the cached analysis (a warm plan: the wave,
the path and its clearance), smooths with :func:`planner.poses.smooth_path`, and checks every
rule with ``tests/naive_poses.py`` (clearance of every point of the polyline, exactly, against
the blocked cells' centers found through the exact EDT). It prints a markdown table::

    .venv/bin/python benchmarks/poses.py            # 24 pairs a map
    .venv/bin/python benchmarks/poses.py --pairs 40
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

import planner
from planner.poses import smooth_path
from tests import naive_poses

REPEAT = 3  # each plan and each smoothing timed this many times: the median counts


def cpu() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return platform.processor() or "unknown CPU"
    fields = dict(line.split(":", 1) for line in out.splitlines() if ":" in line)
    return f"{fields.get('Model name', '?').strip()}, {fields.get('CPU(s)', '?').strip()} CPUs"


def timed(fn: Any) -> tuple[Any, float]:
    """The result of the first call, and the median time of REPEAT calls in ms."""
    times = []
    result = None
    for i in range(REPEAT):
        t0 = time.perf_counter()
        out = fn()
        times.append((time.perf_counter() - t0) * 1e3)
        if i == 0:
            result = out
    return result, statistics.median(times)


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(np.array(values), q)) if values else math.nan


def run_map(path: Path, pairs: int, seed: int) -> dict[str, Any]:
    robot_map = planner.read_ros_map(path)
    res = robot_map.resolution
    small = min(robot_map.shape) * res < 2.0  # testmap: 1 m a side
    radius = 0.1 if small else 0.22
    params = planner.resolve_params("wide", robot_radius=radius)
    analysis = planner.analyse_map(robot_map, params)
    cs = analysis.cspace
    assert cs is not None
    cells = np.argwhere(analysis.passable() == 1)
    span = max(int(np.ptp(cells[:, 0])), int(np.ptp(cells[:, 1])), 1)
    rng = np.random.default_rng(seed)
    frame = robot_map.frame
    yaw = frame.origin[2]
    rows: list[dict[str, float]] = []
    moved = tries = 0
    warm = False
    while len(rows) < pairs and tries < 100 * pairs:
        tries += 1
        s, g = cells[rng.integers(len(cells), size=2)]
        if math.hypot(*(s - g)) < 0.4 * span:
            continue
        ends = []
        for cell in (s, g):
            du, dv = rng.uniform(-0.3, 0.3, size=2) * res
            x, y = frame.centers([cell])[0]
            ends.append(
                {
                    "x": float(x + math.cos(yaw) * du - math.sin(yaw) * dv),
                    "y": float(y + math.sin(yaw) * du + math.cos(yaw) * dv),
                }
            )

        def plan_once(ends: list[dict[str, float]] = ends) -> planner.Plan:
            p = planner.plan(robot_map, ends[0], ends[1], analysis=analysis, robot_radius=radius)
            p.path  # noqa: B018  (the path and its clearance are part of a plan's answer)
            p.min_clearance  # noqa: B018
            return p

        try:
            try:
                plan, plan_ms = timed(plan_once)
            except planner.InvalidInput as error:  # an end point within the radius of a wall
                if error.code not in ("START_OCCUPIED", "GOAL_OCCUPIED"):
                    raise
                moved += 1
                for end, cell in zip(ends, (s, g), strict=True):  # its cell's center instead
                    x, y = frame.centers([cell])[0]
                    end.update(x=float(x), y=float(y))
                plan, plan_ms = timed(plan_once)
        except planner.NoValidPath:
            continue
        goal_yaw = float(rng.uniform(-math.pi, math.pi)) if len(rows) % 2 else None
        kwargs = {
            "resolution": res,
            "origin": frame.origin,
            "robot_radius": radius,
            "outside_blocked": cs.unknown == "blocked",
            "goal_yaw": goal_yaw,
        }

        def smooth(
            point_ends: bool,
            plan: planner.Plan = plan,
            ends: list[dict[str, float]] = ends,
            kwargs: dict[str, Any] = kwargs,
        ) -> Any:
            where: dict[str, Any] = {
                "start": (ends[0]["x"], ends[0]["y"]),
                "goal": (ends[1]["x"], ends[1]["y"]),
            }
            return smooth_path(
                plan.path, analysis.clearance, **kwargs, **(where if point_ends else {})
            )

        point_ends = True
        try:
            smooth(True)
        except planner.InvalidInput as error:  # an end point within the radius of a wall
            if error.field not in ("start", "goal"):
                raise
            point_ends = False
            moved += 1
        if not warm:  # the first call compiles or loads the kernels
            smooth(point_ends)
            warm = True
        poses, smooth_ms = timed(lambda point_ends=point_ends: smooth(point_ends))
        where = (
            {"start": (ends[0]["x"], ends[0]["y"]), "goal": (ends[1]["x"], ends[1]["y"])}
            if point_ends
            else {}
        )
        check = naive_poses.check_poses(poses, plan.path, analysis.clearance, **kwargs, **where)  # type: ignore[arg-type]
        rows.append(
            {
                "ok": float(not check.problems),
                "length": check.length_m / check.grid_length_m,
                "shortcut": check.length_m / check.shortcut_length_m,
                "turning": (
                    (check.turning / check.length_m) / (check.grid_turning / check.grid_length_m)
                    if check.grid_turning > 0
                    else math.nan
                ),
                "clearance": check.min_clearance_m / check.grid_min_clearance_m,
                "plan_ms": plan_ms,
                "smooth_ms": smooth_ms,
                "share": smooth_ms / plan_ms,
                "cells": float(len(plan.path)),
                "poses": float(len(poses)),
            }
        )
        if check.problems:
            print(f"  {path.stem}: {check.problems}", file=sys.stderr)
    turning = [r["turning"] for r in rows if not math.isnan(r["turning"])]
    smooth_times = [r["smooth_ms"] for r in rows]
    plan_times = [r["plan_ms"] for r in rows]
    return {
        "map": path.stem,
        "size": f"{robot_map.shape[1]} x {robot_map.shape[0]}",
        "res": res,
        "radius": radius,
        "plans": len(rows),
        "moved": moved,
        "ok": sum(r["ok"] for r in rows) / max(len(rows), 1),
        "cells": statistics.median(r["cells"] for r in rows),
        "poses": statistics.median(r["poses"] for r in rows),
        "length": statistics.median(r["length"] for r in rows),
        "shortcut": max(r["shortcut"] for r in rows),
        "turning": statistics.median(turning) if turning else math.nan,
        "clearance": min(r["clearance"] for r in rows),
        "plan_ms": statistics.median(plan_times),
        "smooth_ms": statistics.median(smooth_times),
        "smooth_p99": percentile(smooth_times, 99),
        "share": statistics.median(r["share"] for r in rows),
        "share_total": sum(smooth_times) / sum(plan_times),
    }


def table(results: list[dict[str, Any]]) -> str:
    head = (
        "| map | size | res (m) | radius (m) | plans | every rule | median cells / poses | "
        "length poses / grid (median) | poses / greedy shortcut (max) | turning per m poses / "
        "grid (median) | least clearance poses / grid (min) | warm plan ms (median) | smoothing "
        "ms median / p99 | smoothing / plan (median, total) |"
    )
    lines = [head, "|" + "---|" * head.count(" | ") + "---|"]
    for r in results:
        lines.append(
            f"| {r['map']} | {r['size']} | {r['res']:g} | {r['radius']:g} | {r['plans']} | "
            f"{100 * r['ok']:.0f} % | {r['cells']:.0f} / {r['poses']:.0f} | {r['length']:.3f} | "
            f"{r['shortcut']:.3f} | {r['turning']:.3f} | {r['clearance']:.3f} | "
            f"{r['plan_ms']:.2f} | {r['smooth_ms']:.3f} / {r['smooth_p99']:.3f} | "
            f"{100 * r['share']:.1f} %, {100 * r['share_total']:.1f} % |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=24, help="start/goal pairs a map (>= 20)")
    parser.add_argument("--seed", type=int, default=22)
    args = parser.parse_args(argv)
    folder = ros_maps()
    results = []
    for i, path in enumerate(sorted(folder.glob("*.yaml"))):
        results.append(run_map(path, args.pairs, args.seed + i))
        print(f"  {path.stem} done", file=sys.stderr)
    print(f"Poses on the shared ROS maps ({cpu()}, Python {platform.python_version()}):\n")
    print(table(results))
    moved = sum(r["moved"] for r in results)
    if moved:
        print(f"\n{moved} plans' end points were within the radius of a wall: their cells' centers")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

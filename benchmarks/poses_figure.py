"""The figure of ``docs/robot-maps.md``: the grid path (green) and the poses a robot drives (blue)
between seeded far-apart points on a shared ROS map, with a 0.22 m robot::

    .venv/bin/python benchmarks/poses_figure.py            # depot -> docs/figures/poses-depot.png
    .venv/bin/python benchmarks/poses_figure.py --map smoothers_world --seed 3 --pairs 2
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

import planner
from planner.render import draw, draw_poses
from planner.render_legend import COLOURS

RADIUS = 0.22


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--map", default="depot", help="a shared ROS map's name")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--pairs", type=int, default=3)
    parser.add_argument("--cell", type=int, default=3, help="pixels per map cell")
    args = parser.parse_args()
    folder = ros_maps()
    robot_map = planner.read_ros_map(folder / f"{args.map}.yaml")
    params = planner.resolve_params("wide", robot_radius=RADIUS)
    analysis = planner.analyse_map(robot_map, params)
    cells = np.argwhere(analysis.passable() == 1)
    span = max(np.ptp(cells[:, 0]), np.ptp(cells[:, 1]))
    rng = np.random.default_rng(args.seed)
    paths: list[planner.render.LabelledPath] = []
    poses: list[np.ndarray] = []
    first: planner.Plan | None = None
    while len(poses) < args.pairs:
        s, g = cells[rng.integers(len(cells), size=2)]
        if math.hypot(*(s - g)) < span / 2:
            continue
        (sx, sy), (gx, gy) = robot_map.frame.centers([s, g]).tolist()
        goal = {"x": gx, "y": gy, "yaw": float(rng.uniform(-math.pi, math.pi))}
        try:
            plan = planner.plan(
                robot_map, {"x": sx, "y": sy}, goal, analysis=analysis, robot_radius=RADIUS
            )
        except planner.NoValidPath:
            continue
        first = first or plan
        paths.append((plan.path, COLOURS["path"], "grid path" if not paths else ""))
        poses.append(plan.poses)
        print(
            f"{args.map}: grid path {plan.length_m:.2f} m, {len(plan.path)} cells; poses "
            f"{plan.length_poses_m:.2f} m, {len(plan.poses)} poses"
        )
    assert first is not None
    image = draw(
        analysis, paths=paths, start=first.start, goal=first.goal, cell=args.cell, legend=True
    )
    # Every pair's poses over its grid path: draw() takes one set, so the rest go on top.
    for P in poses:
        draw_poses(image, analysis, P, cell=args.cell)
    out = ROOT / "docs" / "figures" / f"poses-{args.map}.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    image.save(out, optimize=True)
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()

"""The figures of ``docs/passages.md``: a shared ROS map with its narrow passages for a round
robot, each labelled with its id and width (one figure for each shared map, as the page says)::

    .venv/bin/python benchmarks/passages_figure.py     # depot -> docs/figures/passages-depot.png
    .venv/bin/python benchmarks/passages_figure.py --map tb3_sandbox --radius 0.22 --cell 3
"""

from __future__ import annotations

import argparse
import sys

from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

import planner


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--map", default="depot", help="a shared ROS map's name")
    parser.add_argument("--radius", type=float, default=0.35, help="the robot's radius, meters")
    parser.add_argument("--max-width", type=float, default=1.0, help="narrow below this, meters")
    parser.add_argument("--cell", type=int, default=2, help="pixels per map cell")
    args = parser.parse_args()
    folder = ros_maps()
    robot_map = planner.read_ros_map(folder / f"{args.map}.yaml")
    found = planner.find_passages(robot_map, args.radius, args.max_width)
    analysis = planner.analyse_map(robot_map, planner.resolve_params(robot_radius=args.radius))
    out = ROOT / "docs" / "figures" / f"passages-{args.map}.png"
    out.write_bytes(planner.render_map(analysis, cell=args.cell, passages=found))
    print(f"wrote {out.relative_to(ROOT)}: {len(found)} passages")
    for p in found:
        print(f"  #{p.id} at ({p.x:.2f}, {p.y:.2f}) m: {p.width_m:.2f} m wide, {p.length_m:.2f} m")


if __name__ == "__main__":
    main()

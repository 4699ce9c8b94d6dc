"""The figure of the fleet roadmap: a shared ROS map's roadmap for a fleet's radius, its edges
as lines and its nodes as discs of the robots' size over the map::

    .venv/bin/python benchmarks/roadmap_figure.py   # docs/figures/fleet-roadmap-depot.png
    .venv/bin/python benchmarks/roadmap_figure.py --map smoothers_world --radius 0.22
"""

from __future__ import annotations

import argparse
import sys

from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

from PIL import ImageDraw

import planner
from planner.fleets.roadmap import build_roadmap

EDGE = (0, 110, 200)
NODE = (230, 80, 0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--map", default="depot", help="a shared ROS map's name")
    parser.add_argument("--radius", type=float, default=0.3, help="the fleet's radius, meters")
    parser.add_argument("--cell", type=int, default=3, help="pixels per map cell")
    args = parser.parse_args()
    robot_map = planner.read_ros_map(ros_maps() / f"{args.map}.yaml")
    params = planner.resolve_params("wide", robot_radius=args.radius)
    analysis = planner.analyse_map(robot_map, params)
    graph = build_roadmap(analysis, radius=args.radius)
    image = planner.render.draw(analysis, cell=args.cell, legend=True)
    pen = ImageDraw.Draw(image)
    cell = args.cell
    centers = (graph.cells[:, ::-1] + 0.5) * cell  # (x, y) pixels
    for u in range(graph.nodes):
        for v in graph.neighbours(u).tolist():
            if u < v:
                (x0, y0), (x1, y1) = centers[u], centers[v]
                pen.line([(x0, y0), (x1, y1)], fill=EDGE, width=max(1, cell // 2))
    # A node's disc has the robot's radius: discs of two nodes never overlap.
    disc = graph.radius / graph.resolution * cell
    for x, y in centers.tolist():
        pen.ellipse([x - disc, y - disc, x + disc, y + disc], outline=NODE, width=1)
        pen.ellipse([x - 2, y - 2, x + 2, y + 2], fill=NODE)
    out = ROOT / "docs" / "figures" / f"fleet-roadmap-{args.map}.png"
    image.save(out, format="PNG", optimize=True)
    print(f"wrote {out.relative_to(ROOT)}: {graph.nodes} nodes, {graph.edges} edges")


if __name__ == "__main__":
    main()

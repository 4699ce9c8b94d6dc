"""The figure of ``docs/shapes.md``: a car (0.6 m x 0.4 m, 0.5 m turning radius, forward and
reverse) parking in a 0.8 m x 1.2 m bay off a 2 m aisle, ending facing out: its outline every
0.3 m, blue forward, orange in reverse::

    .venv/bin/python benchmarks/shapes_figure.py     # -> docs/figures/shapes-parking.png
"""

from __future__ import annotations

import argparse
import sys

from common import ROOT

sys.path.insert(0, str(ROOT))

import planner
from planner.render import draw, draw_poses
from planner.render_shapes import draw_footprints
from tests import naive_shapes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cell", type=int, default=8, help="pixels per map cell")
    args = parser.parse_args()
    bay, start, goal = naive_shapes.parking_bay()
    plan = planner.plan(bay, start, goal, footprint=naive_shapes.RECTANGLE,
                        motion="car_reverse", min_turning_radius=0.5)  # fmt: skip
    motion = plan.motion
    assert motion is not None
    print(f"parking: {plan.length_poses_m:.2f} m, {len(plan.poses)} poses, {motion.cusps} "
          f"cusps, {motion.expansions} nodes, {motion.elapsed_ms:.0f} ms")  # fmt: skip
    image = draw(plan.analysis, start=plan.start, goal=plan.goal, cell=args.cell, legend=True)
    draw_footprints(image, plan.analysis, plan.poses, naive_shapes.RECTANGLE,
                    directions=plan.directions, cell=args.cell)  # fmt: skip
    draw_poses(image, plan.analysis, plan.poses, cell=args.cell)
    out = ROOT / "docs" / "figures" / "shapes-parking.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    image.save(out, optimize=True)
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()

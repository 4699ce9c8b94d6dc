"""The figure of ``docs/zones.md``: ``depot`` zoned (a keepout zone over the middle of the hall,
a speed zone at its west end), a 0.22 m robot's plan across the hall around the keepout and
through the speed zone, as the service draws it (``GET /plan/{plan_id}/render.png``)::

    .venv/bin/python benchmarks/zones_figure.py      # -> docs/figures/zones-depot.png
"""

from __future__ import annotations

import sys

from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

import planner

KEEPOUT = [(13.0, 3.0), (17.0, 3.0), (17.0, 12.0), (13.0, 12.0)]
SPEED = [(2.0, 5.5), (9.0, 5.5), (9.0, 9.5), (2.0, 9.5)]
OUT = ROOT / "docs" / "figures" / "zones-depot.png"


def main() -> None:
    folder = ros_maps()
    depot = planner.read_ros_map(folder / "depot.yaml")
    zoned = planner.zone_map(depot, keepout=[KEEPOUT], speed=[{"polygon": SPEED, "max_speed": 0.3}])
    plan = planner.plan(zoned, {"x": 3.0, "y": 7.5}, {"x": 27.0, "y": 7.5}, robot_radius=0.22)
    OUT.write_bytes(planner.render_plan(plan, cell=2))
    inside = int((plan.max_speeds < float("inf")).sum())
    print(
        f"{OUT.relative_to(ROOT)}: {len(plan.poses)} poses, {inside} in the speed zone, "
        f"{plan.length_poses_m:.2f} m in {plan.duration_s:.1f} s at 0.5 m/s"
    )


if __name__ == "__main__":
    main()

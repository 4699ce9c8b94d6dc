"""The figure of ``docs/live.md``: on ``depot``, robot A (blue, heading east) takes a 1,080-ray
scan (amber rays) that sees a pallet on robot B's way; the pallet's face becomes live marks
(red), and B's route (grey before the scan) goes around them (green after), as the service
plans it: B's session stepped to its goal with the marks as obstacles, each widened by B's
radius, B's own 360-ray scan from each cell updating them on the way::

    .venv/bin/python benchmarks/live_figure.py      # -> docs/figures/live-depot.png
"""

from __future__ import annotations

import itertools
import math
import sys

import numpy as np
from common import ROOT, ros_maps
from live_world import Box, cast

sys.path.insert(0, str(ROOT))

import planner
from planner.render_live import draw_live

RADIUS = 0.22
PALLET = Box(14.7, 7.1, 15.3, 7.9)
A_POSE = (12.2, 9.6, 0.0)
A_GOAL = (24.0, 9.6)
B_START, B_GOAL = (11.0, 7.5), (19.0, 7.5)
OUT = ROOT / "docs" / "figures" / "live-depot.png"


def route(
    session: planner.Session, depot: planner.RobotMap, marks: set[int]
) -> list[tuple[float, float]]:
    """The cell centers the robot passes stepping to its goal around the live ``marks`` (flat
    cells), which its own 360-ray scan from each cell updates before each step."""
    frame = depot.frame
    W = frame.shape[1]
    for seq in range(2000):
        x, y = frame.centers([session.state.position])[0]
        traced = trace(depot, (float(x), float(y), 0.0), rays=360)
        rows, cols = np.nonzero(traced.cleared)
        marks -= set(((rows + traced.top) * W + cols + traced.left).tolist())
        marks |= set(traced.marked.tolist())
        cells = np.array(sorted(marks), dtype=np.int64)
        widened = widen(depot, np.stack([cells // W, cells % W], axis=1))
        if session.step(widened, seq=seq).status == "arrived":
            break
    return [tuple(p) for p in frame.centers(session.state.trajectory).tolist()]


def trace(depot: planner.RobotMap, pose: tuple[float, float, float], rays: int) -> planner.Traced:
    """What a scan at ``pose`` of the map and the pallet marks and clears."""
    frame, blocked = depot.frame, depot.blocked()
    scan = cast(blocked, frame, pose, [PALLET], rays=rays, range_max=12.0)
    ranges = np.array([math.nan if r is None else r for r in scan["ranges"]])
    laser = planner.LaserScan(scan["angle_min"], scan["angle_increment"], 0.05, 12.0, ranges)
    return planner.trace_scan(frame, blocked, laser, pose, robot_radius=RADIUS)


def widen(depot: planner.RobotMap, marks: np.ndarray) -> np.ndarray:
    """The cells the marks block for the robot: each mark's cell widened by its radius."""
    if not len(marks):
        return marks
    half = depot.frame.resolution / 2
    circles = [{"x": x, "y": y, "radius": half} for x, y in depot.frame.centers(marks)]
    return planner.circle_cells(depot, circles, robot_radius=RADIUS)


def _disc(center: tuple[float, float]) -> list[tuple[float, float]]:
    """A robot's outline: its radius round its center."""
    t = np.linspace(0, 2 * math.pi, 25)
    return list(zip(center[0] + RADIUS * np.cos(t), center[1] + RADIUS * np.sin(t), strict=True))


def main() -> None:
    depot = planner.read_ros_map(ros_maps() / "depot.yaml")
    frame, blocked = depot.frame, depot.blocked()
    scan = cast(blocked, frame, A_POSE, [PALLET], rays=1080, range_max=12.0)
    ranges = np.array([math.nan if r is None else r for r in scan["ranges"]])
    laser = planner.LaserScan(scan["angle_min"], scan["angle_increment"], 0.05, 12.0, ranges)
    traced = trace(depot, A_POSE, rays=1080)
    W = frame.shape[1]
    marks = np.stack([traced.marked // W, traced.marked % W], axis=1)
    angles = A_POSE[2] + laser.angle_min + laser.angle_increment * np.arange(len(ranges))
    reach = np.where(np.isnan(ranges), 12.0, ranges)
    ends = np.stack([A_POSE[0] + reach * np.cos(angles), A_POSE[1] + reach * np.sin(angles)], 1)
    b_plan = planner.plan(depot, dict(zip("xy", B_START, strict=True)),
                          dict(zip("xy", B_GOAL, strict=True)), robot_radius=RADIUS)  # fmt: skip
    a_plan = planner.plan(depot, {"x": A_POSE[0], "y": A_POSE[1]},
                          dict(zip("xy", A_GOAL, strict=True)), robot_radius=RADIUS)  # fmt: skip
    before = b_plan.poses[:, :2]
    after = route(planner.Session(b_plan), depot, set(traced.marked.tolist()))
    a_after = route(planner.Session(a_plan), depot, set(traced.marked.tolist()))
    p = PALLET
    outline = [(p.x0, p.y0), (p.x1, p.y0), (p.x1, p.y1), (p.x0, p.y1), (p.x0, p.y0)]
    routes = [
        (before, (150, 150, 150)), (after, (0, 160, 0)), (a_after, (21, 101, 192)),
        (outline, (120, 80, 40)),
        (_disc(A_POSE[:2]), (21, 101, 192)), (_disc(B_START), (0, 160, 0)),
    ]  # fmt: skip
    image = draw_live(depot, marks, cell=3, rays=(A_POSE[:2], ends[::12]), routes=routes)
    # Crop to the hall round the robots (x 6..22 m, y 5..11 m).
    left, right = int(6 / frame.resolution * 3), int(22 / frame.resolution * 3)
    H = frame.shape[0]
    top, bottom = int((H - 11 / frame.resolution) * 3), int((H - 5 / frame.resolution) * 3)
    image.crop((left, top, right, bottom)).save(OUT)
    longer = sum(math.dist(p, q) for p, q in itertools.pairwise(after))
    print(
        f"{OUT.relative_to(ROOT)}: {len(marks)} marks from A's scan; B's route "
        f"{b_plan.length_poses_m:.2f} m before, {longer:.2f} m (grid) after"
    )


if __name__ == "__main__":
    main()

"""Robot shapes and motion on the shared ROS maps, side by side with OMPL, and a rectangle
against its enclosing circle.

For each 0.05 m shared ROS map and seeded far-apart start/goal poses where a 0.6 m x 0.4 m
rectangle fits (a yaw at both ends), it plans:

- a car (0.5 m turning radius; ``car``: Dubins, ``car_reverse``: Reeds-Shepp) with this
  planner (warm: the map's analysis cached) and with OMPL's RRT* on the same state space for
  5 s, with the same footprint check (this planner's table, every centimeter along OMPL's
  motions); path length, plan time, least footprint clearance and greatest curvature;
- the rectangle (``diff``) against a disc of its enclosing circle's radius (0.361 m): routes
  only the rectangle takes, and the length it saves where both go.

It prints markdown tables (docs/performance.md, "Robot shapes and motion")::

    .venv/bin/python benchmarks/shapes.py                  # 6 routes a map, 5 s for OMPL
    .venv/bin/python benchmarks/shapes.py --routes 3 --seconds 2 --motions car
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

import planner
from planner.footprint import footprint_cells, footprint_of
from planner.motion import Grid, densify, footprint_clearance, grid_of, poses_free
from planner.motion.collide import pose_free_at
from tests import naive_shapes

MAPS = ("depot", "tb3_sandbox", "smoothers_world")
RECTANGLE = naive_shapes.RECTANGLE
RADIUS = 0.5
MIN_DISTANCE = 4.0  # meters between a route's ends at least


def routes(robot_map: planner.RobotMap, grid: Grid, count: int, seed: int) -> list[Any]:
    """Seeded start/goal poses ``(x, y, yaw)`` where the rectangle fits with 0.2 m to spare,
    at least ``MIN_DISTANCE`` apart and joined for its inscribed disc."""
    fp = footprint_of(RECTANGLE)
    cells = footprint_cells(fp, robot_map.resolution)
    params = planner.resolve_params("wide", footprint=RECTANGLE)
    analysis = planner.analyse_map(robot_map, params)
    free = np.argwhere(analysis.passable() == 1)
    rng = np.random.default_rng(seed)
    out: list[Any] = []
    for _ in range(4000):
        if len(out) == count:
            break
        ends = []
        for cell in free[rng.integers(len(free), size=2)]:
            x, y = robot_map.frame.centers([cell])[0]
            ends.append((float(x), float(y), float(rng.uniform(-math.pi, math.pi))))
        if math.dist(ends[0][:2], ends[1][:2]) < MIN_DISTANCE:
            continue
        at = grid.to_grid(ends)
        # Room to drive off: a car facing a wall at arm's length has no way out.
        if not poses_free(grid, cells, at).all():
            continue
        if footprint_clearance(grid, cells, at).min() < 0.2:
            continue
        try:
            planner.plan(None, _point(ends[0]), _point(ends[1]), analysis=analysis,
                         footprint=RECTANGLE)  # fmt: skip
        except planner.PlannerError:
            continue
        out.append(ends)
    return out


def _point(pose: tuple[float, float, float]) -> dict[str, float]:
    return {"x": pose[0], "y": pose[1], "yaw": pose[2]}


def measure(grid: Grid, poses: np.ndarray) -> dict[str, float]:
    """Length, least footprint clearance and greatest curvature of map-frame poses."""
    cells = footprint_cells(footprint_of(RECTANGLE), grid.frame.resolution)
    steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    clear = footprint_clearance(grid, cells, grid.to_grid(poses))
    curv = naive_shapes.curvatures(poses)
    return {
        "length": float(steps.sum()),
        "clearance": float(clear.min()),
        "curvature": float(curv.max()) if len(curv) else 0.0,
    }


def ours(
    robot_map: planner.RobotMap, analysis: planner.Analysis, ends: Any, motion: str
) -> dict[str, float] | None:
    t0 = time.perf_counter()
    try:
        plan = planner.plan(
            None, _point(ends[0]), _point(ends[1]), analysis=analysis, footprint=RECTANGLE,
            motion=motion, min_turning_radius=RADIUS,
        )  # fmt: skip
        poses = plan.poses
    except planner.PlannerError:
        return None
    seconds = time.perf_counter() - t0
    return {**measure(grid_of(analysis), poses), "seconds": seconds}


def ompl(grid: Grid, ends: Any, motion: str, seconds: float) -> dict[str, float] | None:
    """OMPL's RRT* on the Reeds-Shepp (``car_reverse``) or Dubins (``car``) space for
    ``seconds``, each state checked by this planner's footprint table, motions every cm."""
    from ompl import base as ob
    from ompl import geometric as og

    space = (
        ob.ReedsSheppStateSpace(RADIUS) if motion == "car_reverse" else ob.DubinsStateSpace(RADIUS)
    )
    H, W = grid.blocked.shape
    res = grid.frame.resolution
    ox, oy, _ = grid.frame.origin
    bounds = ob.RealVectorBounds(2)
    bounds.setLow(0, ox)
    bounds.setHigh(0, ox + W * res)
    bounds.setLow(1, oy)
    bounds.setHigh(1, oy + H * res)
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    cells = footprint_cells(footprint_of(RECTANGLE), res)

    c, s, yaw = math.cos(grid.frame.origin[2]), math.sin(grid.frame.origin[2]), grid.frame.origin[2]
    table = (grid.blocked, grid.distance, cells.offsets, cells.starts, cells.reach,
             grid.outside_blocked)  # fmt: skip

    def valid(state: Any) -> bool:  # the search's own check, called straight
        dx, dy = state.getX() - ox, state.getY() - oy
        u, v = (c * dx + s * dy) / res, (-s * dx + c * dy) / res
        return bool(pose_free_at(*table, u, v, state.getYaw() - yaw))

    setup.setStateValidityChecker(valid)
    info = setup.getSpaceInformation()
    # As often as the search checks its motions (0.45 cells).
    info.setStateValidityCheckingResolution(0.45 * res / space.getMaximumExtent())
    start, goal = space.allocState(), space.allocState()
    for state, (x, y, yaw) in ((start, ends[0]), (goal, ends[1])):
        state.setX(x)
        state.setY(y)
        state.setYaw(yaw)
    setup.setStartAndGoalStates(start, goal)
    rrt = og.RRTstar(info)
    rrt.setRange(1.0)  # meters: short edges, fewer wasted checks
    setup.setPlanner(rrt)
    t0 = time.perf_counter()
    solved = setup.solve(seconds)
    took = time.perf_counter() - t0
    if not solved or not setup.haveExactSolutionPath():
        return None
    path = setup.getSolutionPath()
    path.interpolate(max(2, math.ceil(path.length() / 0.01)))
    states = [path.getState(i) for i in range(path.getStateCount())]
    poses = np.array([(s.getX(), s.getY(), s.getYaw()) for s in states])
    fine = densify(grid.to_grid(poses), 0.01 / res, math.radians(2))
    if not poses_free(grid, cells, fine).all():
        return None
    return {**measure(grid, poses), "seconds": took}


def disc_or_rectangle(
    robot_map: planner.RobotMap, pairs: list[Any]
) -> tuple[int, int, list[float]]:
    """Routes the rectangle takes, routes only it takes, and its length over the enclosing
    disc's where both go (``diff``: both turn in place)."""
    fp = footprint_of(RECTANGLE)
    rect = planner.analyse_map(robot_map, planner.resolve_params("wide", footprint=RECTANGLE))
    disc_p = planner.resolve_params("wide", robot_radius=fp.circumscribed_radius)
    disc = planner.analyse_map(robot_map, disc_p)
    taken = only = 0
    ratios: list[float] = []
    for ends in pairs:
        try:
            a = planner.plan(None, _point(ends[0]), _point(ends[1]), analysis=rect,
                             footprint=RECTANGLE).length_poses_m  # fmt: skip
        except planner.PlannerError:
            continue
        taken += 1
        try:
            b = planner.plan(None, _point(ends[0]), _point(ends[1]), analysis=disc,
                             robot_radius=fp.circumscribed_radius).length_poses_m  # fmt: skip
        except planner.PlannerError:
            only += 1
            continue
        ratios.append(a / b)
    return taken, only, ratios


def gained(robot_map: planner.RobotMap, tries: int, seed: int) -> tuple[int, int]:
    """Routes from where only the rectangle fits (its inscribed disc's configuration space,
    with 0.3 m to spare, but not the enclosing disc's) to a far point where the disc fits too:
    how many were tried (the rectangle fits there at some heading) and how many it drove."""
    fp = footprint_of(RECTANGLE)
    rect = planner.analyse_map(robot_map, planner.resolve_params("wide", footprint=RECTANGLE))
    disc_p = planner.resolve_params("wide", robot_radius=fp.circumscribed_radius)
    disc = planner.analyse_map(robot_map, disc_p)
    grid = grid_of(rect)
    cells = footprint_cells(fp, robot_map.resolution)
    assert rect.cspace is not None
    assert disc.cspace is not None
    only = np.argwhere(
        (rect.passable() == 1) & (disc.cspace.traversable == 0) & (rect.cspace.distance_m > 0.3)
    )
    both = np.argwhere(disc.passable() == 1)
    rng = np.random.default_rng(seed)
    yaws = np.arange(16) * math.pi / 8
    tried = drove = 0
    while tried < tries and len(only) and len(both):
        (sx, sy), (gx, gy) = robot_map.frame.centers(
            [only[rng.integers(len(only))], both[rng.integers(len(both))]]
        ).tolist()
        if math.hypot(gx - sx, gy - sy) < MIN_DISTANCE:
            continue
        at = np.stack([np.full(16, sx), np.full(16, sy), yaws], axis=1)
        fits = poses_free(grid, cells, grid.to_grid(at))
        if not fits.any():
            continue
        tried += 1
        start = {"x": sx, "y": sy, "yaw": float(yaws[fits][0])}
        try:
            plan = planner.plan(None, start, {"x": gx, "y": gy}, analysis=rect, footprint=RECTANGLE)
            plan.poses  # noqa: B018 - the footprint's path is found on first use
            drove += 1
        except planner.PlannerError:
            continue
    return tried, drove


def median(values: list[float]) -> str:
    return f"{statistics.median(values):.3f}" if values else "-"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--routes", type=int, default=6)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--motions", nargs="+", default=["car", "car_reverse"])
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    folder: Path = ros_maps()
    print(f"CPU: {os.cpu_count()} cores; OMPL RRT* {args.seconds:g} s; radius {RADIUS} m\n")
    rows = []
    disc_rows = []
    for name in MAPS:
        robot_map = planner.read_ros_map(folder / f"{name}.yaml")
        params = planner.resolve_params("wide", footprint=RECTANGLE)
        analysis = planner.analyse_map(robot_map, params)
        grid = grid_of(analysis)
        pairs = routes(robot_map, grid, args.routes, args.seed)
        print(f"{name}: {len(pairs)} routes", file=sys.stderr)
        if not pairs:
            continue
        for motion in args.motions:
            ours(robot_map, analysis, pairs[0], motion)  # warm: numba compiled, tables made
            mine, theirs = [], []
            solved = [0, 0]
            for ends in pairs:
                a = ours(robot_map, analysis, ends, motion)
                b = ompl(grid, ends, motion, args.seconds)
                solved[0] += a is not None
                solved[1] += b is not None
                if a is not None and b is not None:
                    mine.append(a)
                    theirs.append(b)
            rows.append((name, motion, len(pairs), solved, mine, theirs))
        disc_rows.append((name, *disc_or_rectangle(robot_map, pairs), *gained(robot_map, 10, 1)))
    print("| map | motion | routes | solved: ours, OMPL, both | length / OMPL's (median, max) | "
          "plan s (median, max) | OMPL s | least clearance m (ours, OMPL) | max curvature 1/m "
          "(ours, OMPL) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for name, motion, n, solved, mine, theirs in rows:
        ratio = [a["length"] / b["length"] for a, b in zip(mine, theirs, strict=True)]
        secs = [a["seconds"] for a in mine]
        print(
            f"| {name} | {motion} | {n} | {solved[0]}, {solved[1]}, {len(mine)} | {median(ratio)}, "
            f"{max(ratio, default=0):.3f} | {median(secs)}, {max(secs, default=0):.3f} | "
            f"{median([b['seconds'] for b in theirs])} | "
            f"{median([a['clearance'] for a in mine])}, "
            f"{median([b['clearance'] for b in theirs])} | "
            f"{max((a['curvature'] for a in mine), default=0):.3f}, "
            f"{max((b['curvature'] for b in theirs), default=0):.3f} |"
        )
    print("\n| map | routes the rectangle takes | only the rectangle | its length / the "
          "disc's (median, max) | from where only it fits: tried, driven |")  # fmt: skip
    print("|---|---|---|---|---|")
    for name, taken, only, ratios, tried, drove in disc_rows:
        print(f"| {name} | {taken} | {only} | {median(ratios)}, {max(ratios, default=0):.3f} | "
              f"{tried}, {drove} |")  # fmt: skip
    sys.stdout.flush()
    os._exit(0)  # OMPL's bindings report leaked objects at a normal exit


if __name__ == "__main__":
    main()

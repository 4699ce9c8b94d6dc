"""The path ahead of a robot with a footprint or a car motion (docs/shapes.md, "Stepping"). On
its plan, it is the plan's own poses (free for the footprint, within the turning radius, each
with its direction) from the one nearest the robot, to the horizon; on a detour round this
step's obstacles (found for the footprint's inscribed disc), the disc's poses ahead as far as
the footprint is free along them and, for a car, they keep its radius. Either way it stops
before the first motion whose footprint would hold the center of a cell of this step's
obstacles or their margin: what a step answers is checked, or not answered."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import shapely

from planner.footprint import HEADING_BINS, FootprintCells, footprint_cells
from planner.motion.collide import Grid, densified, grid_of, motions_free
from planner.motion.hybrid import Robot, check_spacing
from planner.plans.planning import Plan

__all__ = ["shaped_ahead"]


def shaped_ahead(
    plan: Plan,
    robot: Robot,
    disc: npt.NDArray[np.float64],
    obstacles: npt.NDArray[np.int64],
    *,
    on_plan: bool,
    here: tuple[float, float],
    yaw: float | None,
) -> npt.NDArray[np.float64]:
    """The poses ahead of ``robot`` (``(m, 3)``, map frame). ``on_plan``: the plan's own, from
    the one nearest ``here`` to the horizon, the robot's point (with its ``yaw`` if known) put
    first when the motion from it is free and, for a car, keeps the radius; else ``disc`` (the
    disc's poses ahead). Cut before the first motion that is not free for the footprint, nor
    for this step's ``obstacles`` (cells, with the plan's ``dynamic_margin``), or that turns
    tighter than a car can; the first pose always stays (a robot that waits)."""
    a, params = plan.analysis, plan.params
    res = a.frame.resolution
    grid = grid_of(a)
    cells = footprint_cells(robot.footprint, res, bins=HEADING_BINS)
    step, angle = check_spacing(cells)
    if on_plan and plan.motion is not None:
        poses = plan.motion.poses
        i = int(np.argmin(np.hypot(*(poses[:, :2] - here).T)))
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[i:, :2], axis=0).T))])
        poses = poses[i : i + int(np.searchsorted(along, params.horizon_m)) + 1]
        first = np.array([[here[0], here[1], poses[0, 2] if yaw is None else yaw]])
        join = np.concatenate([first, poses[:1]])
        if math.dist(here, poses[0, :2]) > 1e-9 and _ok(grid, cells, join, step, angle, robot)[0]:
            poses = np.concatenate([first, poses])
    else:
        poses = _cut(disc, _ok(grid, cells, disc, step, angle, robot))
    if len(obstacles):
        poses = _cut(poses, _clear_of(plan, robot, poses, obstacles, step * res, angle))
    return poses


def _ok(
    grid: Grid, cells: FootprintCells, poses: npt.NDArray[np.float64], step: float, angle: float,
    robot: Robot,
) -> npt.NDArray[np.bool_]:  # fmt: skip
    """Whether each motion (pose ``i`` to ``i + 1``, map frame) is free for the footprint and,
    for a car, keeps its turning radius (and turns in place nowhere)."""
    ok = motions_free(grid, cells, grid.to_grid(poses), step, angle)
    if robot.motion != "diff" and len(poses) > 1:
        chord = np.hypot(*np.diff(poses[:, :2], axis=0).T)
        turn = np.abs(np.angle(np.exp(1j * np.diff(poses[:, 2]))))
        bend = 2 * np.sin(turn / 2)
        ok &= bend <= chord / robot.min_turning_radius * (1 + 1e-6) + 1e-9
    return ok


def _cut(poses: npt.NDArray[np.float64], ok: npt.NDArray[np.bool_]) -> npt.NDArray[np.float64]:
    """The poses up to the first motion not ``ok`` (the first pose at least)."""
    bad = np.flatnonzero(~ok)
    return poses if len(bad) == 0 else poses[: int(bad[0]) + 1]


def _clear_of(
    plan: Plan,
    robot: Robot,
    poses: npt.NDArray[np.float64],
    obstacles: npt.NDArray[np.int64],
    step_m: float,
    angle: float,
) -> npt.NDArray[np.bool_]:
    """Whether each motion keeps the footprint off the centers of the obstacles' cells and
    their margin: the footprint grown by half the spacing of the poses checked (and the turn
    between two) holds none at any of them, so none lies on the way between."""
    a = plan.analysis
    m = plan.params.dynamic_margin
    span = np.arange(-m, m + 1)
    near = obstacles[:, None, None, :] + np.stack(np.meshgrid(span, span, indexing="ij"), -1)
    near = np.unique(near.reshape(-1, 2), axis=0)
    inside = (near >= 0).all(axis=1) & (near[:, 0] < a.shape[0]) & (near[:, 1] < a.shape[1])
    centers = a.frame.centers(near[inside])
    if len(poses) < 2 or len(centers) == 0:
        return np.ones(max(len(poses) - 1, 0), dtype=bool)
    reach = robot.footprint.circumscribed_radius
    grow = step_m / 2 + reach * angle / 2
    body = shapely.Polygon(robot.footprint.vertices).buffer(grow)
    dense, seg = densified(poses, step_m, angle)
    seg = np.append(seg, len(poses) - 2)  # the last pose ends the last motion
    hit = np.zeros(len(dense), dtype=bool)
    dx = centers[None, :, 0] - dense[:, None, 0]
    dy = centers[None, :, 1] - dense[:, None, 1]
    pi, ci = np.nonzero(dx * dx + dy * dy <= (reach + grow) ** 2)
    if len(pi):
        c, s = np.cos(dense[pi, 2]), np.sin(dense[pi, 2])
        u = c * dx[pi, ci] + s * dy[pi, ci]
        v = -s * dx[pi, ci] + c * dy[pi, ci]
        hit[pi[shapely.intersects_xy(body, u, v)]] = True
    ok = np.ones(len(poses) - 1, dtype=bool)
    ok[seg[hit]] = False
    # A given pose ends the motion before it too.
    ends = np.zeros(len(dense), dtype=bool)
    ends[1:-1] = seg[1:-1] != seg[:-2]
    ok[seg[hit & ends] - 1] = False
    return ok

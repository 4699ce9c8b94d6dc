"""A footprint's path from a start pose to a goal pose on a map's analysis: the hybrid search
(:mod:`planner.motion.search`), its nodes and analytic tail turned into poses at most a cell
apart with their directions, shortened where a straighter curve keeps the clearance
(:mod:`planner.motion.shorten`).

Every motion is checked against the footprint's table (:func:`~planner.footprint.footprint_cells`)
at poses close enough that each pose's table, grown by its ``pad``, covers the way to the next:
so every pose of the answer and every point between two of them is free (the tests check it
exactly, every centimeter and two degrees)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.errors import InvalidInput, NoValidPath
from planner.footprint import HEADING_BINS, Footprint, FootprintCells, footprint_cells
from planner.motion.collide import Grid, grid_of, poses_free
from planner.motion.search import MOTIONS, ROTATE, Costs, Found, hybrid_search, primitives
from planner.motion.shorten import shorten

__all__ = ["MotionPath", "Robot", "check_spacing", "drive"]


@dataclass(frozen=True, slots=True)
class Robot:
    """What drives: its ``footprint``, its ``motion`` (``diff``, ``car``, ``car_reverse``) and,
    for a car, its ``min_turning_radius`` (meters)."""

    footprint: Footprint
    motion: str = "diff"
    min_turning_radius: float = 0.0


@dataclass(frozen=True, eq=False)
class MotionPath:
    """A footprint's path: ``poses`` ``(m, 3)`` ``[x, y, yaw]`` in the map frame, the
    ``direction`` (1 forward, -1 reverse) of the motion reaching each (the first: the
    motion leaving it), and what the search cost."""

    poses: npt.NDArray[np.float64]
    direction: npt.NDArray[np.int8]
    expansions: int
    elapsed_ms: float
    search_s: float = 0.0
    """How long its searches ran (their kernels' compiling left out)."""

    @property
    def cusps(self) -> int:
        """Changes of direction along the path."""
        return int(np.count_nonzero(np.diff(self.direction.astype(np.int64)) != 0))


def drive(
    analysis: Analysis,
    kw: npt.NDArray[np.float64],
    robot: Robot,
    start: tuple[float, float, float | None],
    goal: tuple[float, float, float | None],
    *,
    wide_weight: float,
    wide_distance: float,
    seconds: float = 5.0,
) -> MotionPath:
    """The path of ``robot`` from ``start`` to ``goal`` (``(x, y, yaw or None)`` in meters)
    on ``analysis``, with ``kw`` the goal wave's wide cost-to-go on it (the search's
    heuristic; the analysis is the configuration space of the footprint's inscribed disc).
    The wall term is ``wide``'s (``wide_weight``, ``wide_distance`` meters) of the footprint's
    clearance. The search stops after about ``seconds`` of its own (compiling left out): then
    ``NO_VALID_PATH``."""
    t0 = time.perf_counter()
    if robot.motion not in MOTIONS:
        msg = f"motion must be one of {', '.join(MOTIONS)}; got {robot.motion!r}"
        raise InvalidInput(msg, field="motion")
    car = robot.motion != "diff"
    if car and goal[2] is None:
        msg = (
            f"a {robot.motion} motion needs the goal's yaw (a car cannot turn in place to "
            "meet it): give the goal as {x, y, yaw}"
        )
        raise InvalidInput(msg, field="goal")
    grid = grid_of(analysis)
    res = grid.frame.resolution
    cells = footprint_cells(robot.footprint, res, bins=HEADING_BINS)
    step, angle = check_spacing(cells)
    radius = robot.min_turning_radius / res if car else 0.0
    seeds = _ends(grid, cells, start, "start")
    goals = _ends(grid, cells, goal, "goal")
    moves = primitives(robot.motion, radius, HEADING_BINS, check_step=step, check_angle=angle)
    costs = Costs(wall_weight=wide_weight, wall_distance=wide_distance / res)
    found = hybrid_search(
        grid, cells, kw, moves, seeds, tuple(goals[0]), goal_yaw=goal[2] is not None,
        motion=robot.motion, radius=radius, costs=costs, step=step, angle=angle,
        seconds=seconds,
    )  # fmt: skip
    if not found.found:
        why = f"the search ran out of its {seconds:.3g} s" if found.stopped else "no way fits"
        msg = (
            f"the footprint cannot drive from start to goal with motion {robot.motion} ({why} "
            f"after {found.expansions} nodes)"
        )
        raise NoValidPath(msg, field="goal")
    poses, direction = _poses(found, moves.moves, radius)
    poses, direction = shorten(grid, cells, poses, direction, robot.motion, radius, step)
    out_poses = grid.to_map(poses)
    out_poses[0, :2] = start[:2]
    out_poses[-1, :2] = goal[:2]
    if goal[2] is not None:
        out_poses[-1, 2] = math.remainder(goal[2], 2 * math.pi)
    elapsed = (time.perf_counter() - t0) * 1e3
    return MotionPath(out_poses, direction, found.expansions, elapsed, found.seconds)


def check_spacing(cells: FootprintCells) -> tuple[float, float]:
    """How far apart (cells, radians) poses are checked: then each pose's table covers the
    motion to the next (with a margin for a pose's chord off its arc: the answer's poses are a
    cell apart at most)."""
    return 2 * cells.pad - 0.05, 2 * cells.pad_angle


def _ends(
    grid: Grid, cells: Any, end: tuple[float, float, float | None], name: str
) -> npt.NDArray[np.float64]:
    """An end's grid poses where the footprint is free: its yaw, or (without one) every heading
    bin's center; none free is ``START_OCCUPIED`` / ``GOAL_OCCUPIED``."""
    x, y, yaw = end
    if yaw is None:
        headings = np.arange(HEADING_BINS) * 2 * math.pi / HEADING_BINS + grid.frame.origin[2]
    else:
        headings = np.array([yaw])
    poses = grid.to_grid(np.stack([np.full(len(headings), x), np.full(len(headings), y),
                                   headings], axis=1))  # fmt: skip
    free = poses_free(grid, cells, poses)
    if not free.any():
        at = f"at yaw {yaw:g}" if yaw is not None else "at any heading"
        msg = (
            f"{name} {{'x': {x:g}, 'y': {y:g}}}: the footprint {at} there holds a blocked "
            "cell's center (or leaves the map)"
        )
        raise InvalidInput(msg, field=name, code=f"{name.upper()}_OCCUPIED")
    out: npt.NDArray[np.float64] = np.ascontiguousarray(poses[free])
    return out


def _poses(
    found: Found, moves: npt.NDArray[np.float64], radius: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]]:
    """The search's nodes and tail as poses at most a cell and 15 degrees apart, with the
    direction reaching each."""
    rows: list[npt.NDArray[np.float64]] = [found.poses[:1]]
    dirs: list[npt.NDArray[np.int8]] = [np.ones(1, dtype=np.int8)]
    for i in range(1, len(found.poses)):
        x, y, t = found.poses[i - 1]
        du, dv, dtheta, length, d, kind = moves[found.moves[i]]
        n = max(1, math.ceil(length / 1.0), math.ceil(abs(dtheta) / math.radians(15)))
        f = np.arange(1, n + 1) / n
        if kind == ROTATE or dtheta == 0:
            local = np.stack([f * du, f * dv, f * dtheta], axis=1)
        else:
            a = f * dtheta
            side = 1.0 if dtheta * d > 0 else -1.0
            local = np.stack([radius * np.sin(np.abs(a)) * d, side * radius * (1 - np.cos(a)), a],
                             axis=1)  # fmt: skip
        c, s = math.cos(t), math.sin(t)
        rows.append(
            np.stack(
                [
                    x + c * local[:, 0] - s * local[:, 1],
                    y + s * local[:, 0] + c * local[:, 1],
                    t + local[:, 2],
                ],
                axis=1,
            )
        )
        dirs.append(np.full(n, int(d), dtype=np.int8))  # fmt: skip
    # The tail was checked every 0.45 cells: every other of its poses is enough for an answer
    # (at most a cell apart), and halves the poses the shortening goes over.
    keep = np.zeros(len(found.tail), dtype=bool)
    keep[::2] = True
    keep[-1] = True
    keep[:-1] |= found.tail_direction[:-1] != found.tail_direction[1:]  # a cusp stays a pose
    keep[0] = False
    rows.append(found.tail[keep])
    dirs.append(found.tail_direction[keep])
    poses = np.concatenate(rows)
    direction = np.concatenate(dirs)
    if len(direction) > 1:
        direction[0] = direction[1]
    keep = np.ones(len(poses), dtype=bool)
    keep[1:] = np.abs(np.diff(poses, axis=0)).max(axis=1) > 1e-9
    return poses[keep], direction[keep]

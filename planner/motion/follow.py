"""A footprint turning in place (``diff``) follows the plan's own poses, the grid route smoothed
for its inscribed disc, wherever the footprint is free along them; only the stretches where it
is not are driven by the hybrid search, between free poses of the route about a meter before
and after (then three meters), and the whole way when that fails too.

The grid route keeps to the wide floor and its smoothing straightens it within the route's
clearance; the hybrid search's 5-degree lattice, shortened, is longer on open floor. So where
the footprint fits along the disc's poses (nearly everywhere on the shared maps), its path is
the disc's."""

from __future__ import annotations

import time

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.errors import NoValidPath
from planner.footprint import HEADING_BINS, footprint_cells
from planner.motion.collide import grid_of, motions_free, poses_free
from planner.motion.hybrid import MotionPath, Robot, check_spacing, drive

__all__ = ["MARGINS_M", "follow"]

MARGINS_M = (1.0, 3.0)
"""Meters of the route kept off either side of a stretch the hybrid search drives instead, as
tried in turn."""

End = tuple[float, float, float | None]
"""A path's end: ``(x, y, yaw or None)``, meters and radians."""


def follow(
    analysis: Analysis,
    kw: npt.NDArray[np.float64],
    robot: Robot,
    guide: npt.NDArray[np.float64],
    start: End,
    goal: End,
    *,
    wide_weight: float,
    wide_distance: float,
    seconds: float,
) -> MotionPath:
    """The path of a ``diff`` ``robot`` along ``guide`` (map-frame poses ``(m, 3)`` from
    ``start`` to ``goal``, ``(x, y, yaw or None)``, at most a cell apart), each stretch where
    its footprint is not free driven by :func:`~planner.motion.hybrid.drive` instead (``kw``,
    ``wide_weight``, ``wide_distance`` as there; the whole way from ``start`` to ``goal`` when
    a stretch cannot be mended), the searches within about ``seconds`` in all."""
    t0 = time.perf_counter()
    spent = 0.0  # the searches' own seconds (a kernel's first compiling left out)
    grid = grid_of(analysis)
    cells = footprint_cells(robot.footprint, grid.frame.resolution, bins=HEADING_BINS)
    step, angle = check_spacing(cells)
    at = grid.to_grid(guide)
    ends = poses_free(grid, cells, at[[0, -1]])
    ok = motions_free(grid, cells, at, step, angle)

    def search(a: End, b: End, costs: npt.NDArray[np.float64]) -> MotionPath:
        nonlocal spent
        began = time.perf_counter()
        try:
            found = drive(
                analysis, costs, robot, a, b,
                wide_weight=wide_weight, wide_distance=wide_distance,
                seconds=max(1e-3, seconds - spent),
            )  # fmt: skip
        except NoValidPath:
            spent += time.perf_counter() - began
            raise
        spent += found.search_s
        return found

    if not ends.all():  # the start or the goal does not fit: the search says which
        return search(start, goal, kw)
    if ok.all():
        elapsed = (time.perf_counter() - t0) * 1e3
        return MotionPath(guide.copy(), np.ones(len(guide), dtype=np.int8), 0, elapsed)
    # Near a stretch, the goal wave's cost-to-go says nothing of the way to its far end: the
    # search's heuristic is then the straight distance alone (the wave's reach kept).
    near = np.where(np.isfinite(kw), 0.0, np.inf)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(guide[:, :2], axis=0).T))])
    expansions = 0
    for margin in MARGINS_M:
        rows: list[npt.NDArray[np.float64]] = []
        dirs: list[npt.NDArray[np.int8]] = []
        last = 0
        try:
            for a, b in _windows(~ok, along, margin):
                piece = search(_pose(guide[a]), _pose(guide[b]), near)
                expansions += piece.expansions
                rows += [guide[last:a], piece.poses]
                dirs += [np.ones(a - last, dtype=np.int8), piece.direction]
                last = b + 1
        except NoValidPath:
            if spent >= seconds:
                raise
            continue
        rows.append(guide[last:])
        dirs.append(np.ones(len(guide) - last, dtype=np.int8))
        elapsed = (time.perf_counter() - t0) * 1e3
        return MotionPath(np.concatenate(rows), np.concatenate(dirs), expansions, elapsed, spent)
    return search(start, goal, kw)


def _windows(
    bad: npt.NDArray[np.bool_], along: npt.NDArray[np.float64], margin: float
) -> list[tuple[int, int]]:
    """The pose index pairs ``(a, b)`` around each run of bad motions (``bad[i]``: from pose
    ``i`` to ``i + 1``), ``margin`` meters of the route further on each side (within its
    ends), overlapping ones merged."""
    out: list[tuple[int, int]] = []
    idx = np.flatnonzero(bad)
    for i in idx:
        a = int(np.searchsorted(along, along[i] - margin, side="right")) - 1
        b = int(np.searchsorted(along, along[i + 1] + margin, side="left"))
        a, b = max(a, 0), min(b, len(along) - 1)
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def _pose(row: npt.NDArray[np.float64]) -> End:
    return float(row[0]), float(row[1]), float(row[2])

"""Smooth poses from a grid path: a line-of-sight shortcut that keeps the path's clearance, its
corners rounded by arcs checked against the blocked cells, resampled at most one cell apart, each
pose with its heading.

Clearance is the distance from a point to the nearest blocked cell's center. Every point of the
poses' polyline (not only the poses) keeps more than the robot's radius, at least the grid path's
least clearance minus one cell, and more than half a cell's diagonal (so that, with a radius under
a cell, the line never cuts a blocked cell's corner nor crosses a gate); the segments and arcs
are checked exactly by :mod:`planner.poses.clearance`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.errors import InvalidInput, quote
from planner.parsing import number
from planner.parsing import point as parse_point
from planner.poses.clearance import Sight, threshold
from planner.poses.polyline import BLOCKED, JUMP, OUTSIDE, Setting, polyline_of, poses_along

__all__ = ["MAX_TURN", "smooth_path"]

MAX_TURN = math.radians(15.0)
"""The most a pose's heading turns from the previous pose's."""

_BISECT = 10  # halvings of a corner's tangent length while its arc is not clear


def _without_loops(cells: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """The path with every loop cut out (a cell it comes back to is kept once): a decision
    that wanders (the paper's, with its tabu list) doubles back, and a robot driving the
    poses need not. Consecutive cells stay neighbours, so the path stays a path."""
    if len(np.unique(cells, axis=0)) == len(cells):
        return cells
    seen: dict[tuple[int, int], int] = {}
    keep: list[int] = []
    pairs = [(int(r), int(c)) for r, c in cells.tolist()]
    for i, key in enumerate(pairs):
        if key in seen:
            cut = seen[key]
            for j in keep[cut + 1 :]:
                del seen[pairs[j]]
            del keep[cut + 1 :]
        else:
            seen[key] = len(keep)
            keep.append(i)
    return np.ascontiguousarray(cells[keep])


def smooth_path(
    path: Any,
    distance: Any,
    *,
    resolution: float = 1.0,
    origin: Any = (0.0, 0.0, 0.0),
    robot_radius: float = 0.0,
    start: Any = None,
    goal: Any = None,
    start_yaw: float | None = None,
    goal_yaw: float | None = None,
    outside_blocked: bool = True,
) -> npt.NDArray[np.float64]:
    """Poses ``(m, 3)`` ``[x, y, yaw]`` in meters that a robot can drive along a grid ``path``.

    ``path``: ``(n, 2)`` ``[row, col]`` cells, each step to one of the 8 neighbours (a plan's
    ``path``). ``distance``: from each cell's center to the nearest blocked cell's center, in
    cells, 0 on blocked cells (a plan's ``analysis.clearance``: the exact EDT of the map's
    blocked cells); ``outside_blocked``: whether the map's outside counts as blocked, as it did
    for that transform (a robot map's ``cspace.unknown == "blocked"``; True on plain grids).
    ``resolution`` and ``origin`` ``(x, y, yaw)`` place the cells in meters as ROS does: cell
    ``[row, col]``'s center is ``x = ox + (col + 0.5) res``, ``y = oy + (H - 1 - row + 0.5)
    res``, rotated by ``yaw`` about ``(ox, oy)``. ``start`` and ``goal`` are points ``(x, y)``
    or ``{"x", "y"}`` in meters (default: the first and last cells' centers), normally within
    those cells; ``start_yaw`` and ``goal_yaw`` optional headings in radians.

    The poses go from ``start`` to ``goal`` at most one ``resolution`` apart. Every point of
    their polyline is more than ``robot_radius`` from every blocked cell's center, and at least
    the path's least clearance less one ``resolution`` (and more than half a cell's diagonal: it
    cuts no blocked cell's corner). Each yaw is the direction of travel
    (the last: ``goal_yaw`` when given), turning at most 15 degrees from one pose to the next;
    poses at one point that differ only in yaw (a turn in place) come only first, from
    ``start_yaw`` to the first heading, and last, to ``goal_yaw``. The polyline is the greedy
    line-of-sight shortcut of ``start``, the cells' centers and ``goal`` that keeps that
    clearance, its corners rounded by the widest arcs that keep it too: never longer than the
    path (with the start's and goal's offsets from their cells' centers), nor than the shortcut.

    Raises :class:`~planner.InvalidInput` naming the argument at fault; ``START_OCCUPIED`` /
    ``GOAL_OCCUPIED`` when the robot at the start (goal) point, or on its way to the first
    (from the last) cell's center, would come within its radius of a blocked cell.

    >>> import planner
    >>> grid = [[0, 0, 0, 0, 0, 0],
    ...         [0, 0, 0, 1, 1, 0],
    ...         [0, 0, 0, 1, 1, 0],
    ...         [0, 0, 0, 0, 0, 0]]
    >>> p = planner.plan(grid, [3, 0], [0, 5], preset="shortest")
    >>> poses = smooth_path(p.path, p.analysis.clearance, start=(0.3, 0.4))
    >>> poses[0].round(3).tolist(), poses[-1].round(3).tolist()
    ([0.3, 0.4, 0.77], [5.5, 3.5, 0.0])
    >>> smooth_path([[0, 0], [0, 2]], p.analysis.clearance)
    Traceback (most recent call last):
    ...
    planner.errors.InvalidInput: path steps must each go to one of the 8 neighbouring cells; \
step 0 goes from [0, 0] to [0, 2]
    """
    D = np.asarray(distance)
    if D.ndim != 2 or D.size == 0 or D.dtype.kind not in "fiu":
        msg = f"distance must be a 2-D array of distances in cells; got shape {D.shape!r}"
        raise InvalidInput(f"{msg}, dtype {D.dtype}", field="distance")
    D = np.ascontiguousarray(D, dtype=np.float32)
    H, W = D.shape
    cells = np.asarray(path)
    if cells.ndim != 2 or cells.shape[1:] != (2,) or len(cells) == 0:
        msg = f"path must be an (n, 2) array of [row, col] cells, n >= 1; got shape {cells.shape!r}"
        raise InvalidInput(msg, field="path")
    if cells.dtype.kind not in "iu" and (
        cells.dtype.kind != "f" or not np.array_equal(cells, np.round(cells))
    ):
        raise InvalidInput(f"path must hold whole cells; got {quote(path)}", field="path")
    cells = _without_loops(np.ascontiguousarray(cells, dtype=np.int64))
    res = number(resolution, "resolution", "a number of meters > 0")
    if res <= 0:
        msg = f"resolution must be > 0 meters; got {quote(resolution)}"
        raise InvalidInput(msg, field="resolution")
    if isinstance(origin, str | bytes | Mapping) or len(origin) != 3:
        raise InvalidInput(f"origin must be (x, y, yaw); got {quote(origin)}", field="origin")
    ox, oy, oyaw = (number(v, "origin", "(x, y, yaw) of finite numbers") for v in origin)
    radius = number(robot_radius, "robot_radius", "a number of meters >= 0")
    if radius < 0:
        msg = f"robot_radius must be >= 0 meters; got {quote(robot_radius)}"
        raise InvalidInput(msg, field="robot_radius")
    yaws = []
    for name, yaw in (("start_yaw", start_yaw), ("goal_yaw", goal_yaw)):
        yaws.append(None if yaw is None else number(yaw, name, "a finite number of radians"))
    cos_o, sin_o = math.cos(oyaw), math.sin(oyaw)

    def to_cells(point: Any, name: str) -> tuple[float, float]:
        x, y = parse_point(point, name, also=("yaw",))
        u = (cos_o * (x - ox) + sin_o * (y - oy)) / res
        v = (-sin_o * (x - ox) + cos_o * (y - oy)) / res
        slack = 1e-9 * (H + W)
        if not (-slack <= u <= W + slack and -slack <= v <= H + slack):
            msg = f"{name} {quote(point)} is outside the {H} x {W} map of {res:g} m cells"
            raise InvalidInput(msg, field=name)
        return u - 0.5, v - H + 0.5  # X = col, Y = -row

    first, last = (
        (float(cells[0, 1]), float(-cells[0, 0])),
        (float(cells[-1, 1]), float(-cells[-1, 0])),
    )
    s = first if start is None else to_cells(start, "start")
    g = last if goal is None else to_cells(goal, "goal")
    V, index, least, wrong, i = polyline_of(cells, D, (*s, *g))
    if wrong == OUTSIDE:
        msg = f"path cell {cells[i].tolist()} (index {i}) is outside the {H} x {W} map"
        raise InvalidInput(msg, field="path")
    if wrong == JUMP:
        msg = (
            "path steps must each go to one of the 8 neighbouring cells; step "
            f"{i} goes from {cells[i].tolist()} to {cells[i + 1].tolist()}"
        )
        raise InvalidInput(msg, field="path")
    if wrong == BLOCKED:
        msg = f"path cell {cells[i].tolist()} (index {i}) is blocked: its distance is 0"
        raise InvalidInput(msg, field="path")
    bound, T = threshold(least, radius / res)
    none = np.zeros((0, 0), dtype=np.uint8)  # no mask: the blocked cells' distances alone
    sight = Sight(T, math.sqrt(T), bool(outside_blocked), 0, 0)
    setting = Setting(
        _BISECT, False, res, ox, oy, oyaw, yaws[0] or 0.0, yaws[0] is not None, yaws[1] or 0.0,
        yaws[1] is not None,
    )  # fmt: skip
    poses, bad, _, _ = poses_along(D, V, none, sight, setting)
    if bad >= 0:
        a, b = int(index[bad]), int(index[bad + 1])
        need = (
            f"more than robot_radius {radius:g} m and than half a cell's diagonal "
            f"{math.sqrt(0.5) * res:.6g} m, and at least {bound * res:.6g} m (the path's "
            f"least clearance {least * res:.6g} m less one cell)"
        )
        if a == 0 or b == len(cells) + 1:
            name = "start" if a == 0 else "goal"
            point, cell = (start, cells[0]) if a == 0 else (goal, cells[-1])
            msg = (
                f"{name.upper()}_OCCUPIED: the robot at {name} {quote(point)}, on its way "
                f"{'to' if a == 0 else 'from'} cell {cell.tolist()}'s center, would come too "
                f"near a blocked cell: it needs {need}"
            )
            raise InvalidInput(msg, field=name, code=f"{name.upper()}_OCCUPIED")
        msg = (
            f"the path's step from {cells[a - 1].tolist()} to {cells[b - 1].tolist()} is not "
            f"clear: every point needs {need}; is it a path of this map's traversable cells?"
        )
        raise InvalidInput(msg, field="path")
    out: npt.NDArray[np.float64] = poses
    # The start and goal points as given, to the bit, with the turns in place standing there.
    for point, name, rows in ((start, "start", out), (goal, "goal", out[::-1])):
        if point is not None:
            there = (rows[:, 0] == rows[0, 0]) & (rows[:, 1] == rows[0, 1])
            run = len(rows) if there.all() else int(np.argmin(there))
            rows[:run, 0], rows[:run, 1] = parse_point(point, name, also=("yaw",))
    return out

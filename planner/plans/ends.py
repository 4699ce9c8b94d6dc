"""A plan's ends in meters: the start and goal points as given, their headings, whether the robot
can stand on an off-center point, and the goal used within a ``goal_tolerance``."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from planner.analysis.analyse import Analysis
from planner.analysis.cells import BLOCKED_CELL
from planner.errors import InvalidInput, quote
from planner.maps.frames import point_xy
from planner.maps.grids import as_cell
from planner.poses.smooth import smooth_path

__all__ = [
    "cell_of",
    "end_point",
    "end_yaw",
    "free_cell",
    "nearest_reachable",
    "stand_on",
    "tolerance_m",
]


def end_yaw(value: Any, name: str) -> float | None:
    """The heading a point ``{"x", "y", "yaw"}`` carries (radians, finite), or None."""
    if not isinstance(value, Mapping) or value.get("yaw") is None:
        return None
    yaw = value["yaw"]
    ok = isinstance(yaw, int | float | np.integer | np.floating) and not isinstance(yaw, bool)
    if not ok or not math.isfinite(float(yaw)):
        field = f"{name}.yaw"
        raise InvalidInput(
            f"{field} must be a finite number of radians; got {quote(yaw)}", field=field
        )
    return float(yaw)


def tolerance_m(value: Any) -> float:
    """``goal_tolerance`` checked: a finite number of meters >= 0."""
    ok = isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool)
    if not ok or not math.isfinite(float(value)) or float(value) < 0:
        msg = f"goal_tolerance must be a finite number of meters >= 0; got {quote(value)}"
        raise InvalidInput(msg, field="goal_tolerance")
    return float(value)


def end_point(
    analysis: Analysis, value: Any, cell: tuple[int, int], name: str
) -> tuple[float, float]:
    """A point ``{"x", "y"}`` as given, or a cell's center, in meters."""
    if isinstance(value, Mapping):
        return point_xy(value, name=name)
    x, y = analysis.frame.centers([cell])[0]
    return float(x), float(y)


def cell_of(analysis: Analysis, cell: Any, name: str) -> tuple[int, int]:
    """A ``[row, col]`` cell, or the cell containing a point ``{"x", "y"}`` in meters."""
    if isinstance(cell, Mapping):
        return analysis.frame.cell_of(cell, name=name)
    return as_cell(cell, analysis.shape, name=name)


def free_cell(analysis: Analysis, cell: Any, name: str, code: str | None = None) -> tuple[int, int]:
    """:func:`cell_of`, refused when the robot cannot stand there: on an obstacle, or (named
    ``code``, by default ``{NAME}_OCCUPIED``) within its clearance margin; the message quotes a
    point as sent."""
    point = isinstance(cell, Mapping)
    r, c = cell_of(analysis, cell, name)
    if analysis.state[r, c] != BLOCKED_CELL:
        return r, c
    where = f"{name} {quote(cell)} (cell [{r}, {c}])" if point else f"{name} [{r}, {c}]"
    cs = analysis.cspace
    code = code or f"{name.upper()}_OCCUPIED"
    if cs is not None and cs.unknown_cells[r, c]:
        why = (
            f"{code}: {where} is in unknown space, which the map's `unknown` setting "
            f"({cs.unknown!r}) blocks (`unknown: free` plans through it)"
        )
    elif cs is None or cs.blocked[r, c]:
        why = f"{code}: {where} is on an obstacle"
    else:
        clearance = float(cs.distance[r, c]) * cs.resolution
        why = (
            f"{code}: {where} is not traversable: its clearance {clearance:.3f} m "
            f"is not more than robot_radius {cs.robot_radius:g} m"
        )
    raise InvalidInput(why + _nearest_hint(analysis, (r, c), name), field=name, code=code)


NEAREST_SEARCH = 256
"""Cells around a refused start or goal searched for the nearest free one (an error's hint)."""


def _nearest_hint(analysis: Analysis, cell: tuple[int, int], name: str) -> str:
    """ "; the nearest free cell is ...", in meters too on a robot map, and for a goal the
    ``goal_tolerance`` that would reach it; a bounded search (an error must stay cheap)."""
    H, W = analysis.shape
    r, c = cell
    r0, r1 = max(r - NEAREST_SEARCH, 0), min(r + NEAREST_SEARCH + 1, H)
    c0, c1 = max(c - NEAREST_SEARCH, 0), min(c + NEAREST_SEARCH + 1, W)
    free = np.argwhere(analysis.state[r0:r1, c0:c1] != BLOCKED_CELL)
    if not len(free):
        return f"; no free cell within {NEAREST_SEARCH} cells"
    free += (r0, c0)
    d = np.hypot(free[:, 0] - r, free[:, 1] - c)
    best = free[int(np.argmin(d))]
    fr, fc = int(best[0]), int(best[1])
    hint = f"; the nearest free cell is [{fr}, {fc}]"
    if analysis.cspace is not None:
        x, y = analysis.frame.centers([[fr, fc]])[0]
        meters = float(d.min()) * analysis.frame.resolution
        hint += f", the point {{x: {x:.3f}, y: {y:.3f}}}, {meters:.3f} m away"
        if name == "goal":
            hint += f" (a goal_tolerance of {meters + 1e-3:.3f} m would take it)"
    return hint


def _smoothing_args(analysis: Analysis) -> dict[str, Any]:
    frame, cs = analysis.frame, analysis.cspace
    return {
        "resolution": frame.resolution,
        "origin": frame.origin,
        "robot_radius": cs.robot_radius if cs is not None else 0.0,
        "outside_blocked": cs is None or cs.unknown == "blocked",
    }


def _point_clearance(analysis: Analysis, xy: tuple[float, float], cell: tuple[int, int]) -> float:
    """The distance in meters from a point to the nearest blocked cell's center (the outside's
    ring too when it counts as blocked), by brute force around its cell."""
    D = analysis.clearance
    H, W = D.shape
    r, c = cell
    reach = math.ceil(float(D[r, c])) + 2 if math.isfinite(float(D[r, c])) else max(H, W) + 2
    r0, r1, c0, c1 = r - reach, r + reach + 1, c - reach, c + reach + 1
    rows, cols = np.mgrid[r0:r1, c0:c1]
    inside = (rows >= 0) & (rows < H) & (cols >= 0) & (cols < W)
    blocked = np.zeros(rows.shape, dtype=bool)
    blocked[inside] = D[rows[inside], cols[inside]] == 0
    if _smoothing_args(analysis)["outside_blocked"]:
        blocked |= ~inside & (rows >= -1) & (rows <= H) & (cols >= -1) & (cols <= W)
    if not blocked.any():
        return math.inf
    centers = analysis.frame.centers(np.stack([rows[blocked], cols[blocked]], axis=1))
    return float(np.hypot(centers[:, 0] - xy[0], centers[:, 1] - xy[1]).min())


def stand_on(
    analysis: Analysis, value: Any, cell: tuple[int, int], name: str, code: str | None = None
) -> None:
    """Refuse an off-center point (``{"x", "y"}``) the robot cannot stand on though its cell is
    traversable: ``code`` (by default ``{NAME}_OCCUPIED``; a name other than ``start`` is
    checked as a goal) when it, or the way between it and its cell's center, comes
    within the robot's radius (or half a cell's diagonal) of a blocked cell's center: the rule
    of the poses (see :func:`~planner.poses.smooth_path`)."""
    if not isinstance(value, Mapping):
        return
    start, goal = (value, None) if name == "start" else (None, value)
    try:
        smooth_path(
            [list(cell)], analysis.clearance, start=start, goal=goal, **_smoothing_args(analysis)
        )
    except InvalidInput as error:
        if error.code not in ("START_OCCUPIED", "GOAL_OCCUPIED"):
            raise
        xy = point_xy(value, name=name)
        args = _smoothing_args(analysis)
        res = args["resolution"]
        clearance = _point_clearance(analysis, xy, cell)
        way = "to" if name == "start" else "from"
        code = code or f"{name.upper()}_OCCUPIED"
        msg = (
            f"{code}: {name} {quote(value)} (cell [{cell[0]}, {cell[1]}]) is too "
            f"near an obstacle: its clearance is {clearance:.4f} m; the robot there and on its "
            f"way {way} its cell's center needs more than robot_radius "
            f"{args['robot_radius']:g} m and than half a cell's diagonal "
            f"{res * math.sqrt(0.5):.4f} m"
        )
        raise InvalidInput(msg, field=name, code=code) from None


def nearest_reachable(
    analysis: Analysis,
    start: tuple[int, int],
    goal_xy: tuple[float, float],
    tolerance: float,
    *,
    diagonal_cost: float,
    allow_narrow: bool,
    fits: Callable[[npt.NDArray[np.float64]], npt.NDArray[np.bool_]] | None = None,
) -> tuple[int, int] | None:
    """The traversable cell whose center is nearest to ``goal_xy`` (ties: row, then column),
    within ``tolerance`` meters, that the robot at ``start`` can reach (over the sealed grid, or
    through tight tunnels when ``allow_narrow``), and where ``fits`` (given the centers, meters:
    a footprint's check) if given; None when there is none. ``diagonal_cost`` does not change
    what is reached."""
    frame = analysis.frame
    H, W = analysis.shape
    res = frame.resolution
    # The goal in the cells' own coordinates (a cell's center at integer row and column):
    # distances are the same in meters (times ``res``) whatever the frame's yaw.
    ox, oy, yaw = frame.origin
    dx, dy = goal_xy[0] - ox, goal_xy[1] - oy
    u = (math.cos(yaw) * dx + math.sin(yaw) * dy) / res - 0.5
    v = H - 0.5 - (-math.sin(yaw) * dx + math.cos(yaw) * dy) / res
    reach = tolerance / res * (1 + 1e-12)
    r0, r1 = max(math.floor(v - reach), 0), min(math.ceil(v + reach) + 1, H)
    c0, c1 = max(math.floor(u - reach), 0), min(math.ceil(u + reach) + 1, W)
    if r0 >= r1 or c0 >= c1:
        return None
    # Only the tolerance's disc is looked at: a window of distances (float32: a tolerance of
    # 100 m at 0.05 m is 16 M cells, 64 MB), the cells not reached masked out.
    rows = np.arange(r0, r1, dtype=np.float64)[:, None] - v
    cols = np.arange(c0, c1, dtype=np.float64)[None, :] - u
    dist = np.hypot(rows.astype(np.float32), cols.astype(np.float32))
    dist[dist > reach] = np.inf
    reached = np.zeros(dist.shape, dtype=bool)
    grids = [False, True] if analysis.sealed and allow_narrow else [False]
    for narrow in grids:
        # Reachable over the grid: a diagonal move needs both its orthogonal cells passable, so
        # the cells a wave from the start reaches are its 4-connected piece of the grid (found
        # by labelling, without a cost field over the whole map).
        passable = analysis.passable(narrow=narrow)
        passable[start] = 1
        labels, _ = ndimage.label(passable)
        reached |= labels[r0:r1, c0:c1] == labels[start]
    dist[~reached] = np.inf
    if fits is not None:
        near = np.argwhere(np.isfinite(dist))
        dist[tuple(near[~fits(frame.centers(near + np.array([r0, c0])))].T)] = np.inf
    best = float(dist.min())
    if not math.isfinite(best):
        return None
    # Ties (within float32's rounding): the first in row-major order, the lowest row then column.
    r, c = np.argwhere(dist <= best * (1 + 1e-6))[0]
    return int(r) + r0, int(c) + c0

"""The path ahead of a stepping robot: poses from its point along the clear part of a short piece
of its route, by the rules of :func:`~planner.poses.smooth_path`, and entering no cell that this
step's dynamic obstacles block.

The smoothing is :mod:`planner.poses.smooth`'s (the greedy line-of-sight shortcut, corners
rounded by the widest clear arcs, resampled at most one cell apart), with one more test on every
segment and arc: it enters no blocked cell's square. Those cells are a small window's mask,
stamped here from the obstacles' cells and their margin.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.poses.blocked import _reach
from planner.poses.polyline import _fan_steps, _wrap
from planner.poses.smooth import _SQUARE, _TIE, _poses, _vertices

__all__ = ["poses_ahead"]

_HALVINGS = 6  # of a corner's tangent length while its arc is not clear (a plan's poses: 10)

# What the smoothing of one piece reads besides the polyline and the start's heading: T, its
# root, the mask and its corner (top, left), the resolution and the origin (x, y, yaw).
_Fixed = tuple[float, float, npt.NDArray[np.uint8], int, int, float, float, float, float]


@njit(cache=True, nogil=True)
def _ahead(
    D: Any, outside: bool, V: Any, T: float, root: float, mask: Any, top: int, left: int,
    res: float, ox: float, oy: float, oyaw: float, start_yaw: float, has_start_yaw: bool,
    sx: float, sy: float, exact: bool,
) -> tuple[Any, int, float]:  # fmt: skip
    """Poses (m, 3) x, y, yaw in meters along the polyline V (cells, X = col, Y = -row), as
    ``smooth._poses`` makes them with no goal yaw, clear of ``mask`` too; -1, or the index of a
    step of V that is not clear (then no poses); and their length in meters. With ``exact``,
    the poses at V's first vertex stand at (sx, sy) to the bit, and the first yaw is
    ``start_yaw`` to the bit when it is in (-pi, pi]."""
    # No blocked cell near: an empty mask (the plan's own shortcut, faster along corridors).
    # An arc near a corner keeps the static clearance, not necessarily out of the blocked
    # cells: each is checked whatever its size (``masked``).
    shown = mask if mask.any() else np.zeros((0, 0), dtype=np.uint8)
    out, bad, first_yaw = _poses(
        D, outside, V, T, root, shown, top, left, True, _HALVINGS, res, ox, oy, oyaw,
        start_yaw, has_start_yaw, 0.0, False,
    )  # fmt: skip
    if bad >= 0:
        return out, bad, 0.0
    n_start = _fan_steps(start_yaw, first_yaw) if has_start_yaw else 0
    count = out.shape[0]
    if exact:
        for q in range(n_start + 1):
            out[q, 0], out[q, 1] = sx, sy
    if has_start_yaw and -math.pi < start_yaw <= math.pi:
        out[0, 2] = start_yaw
    length = 0.0
    for q in range(count - 1):
        length += math.hypot(out[q + 1, 0] - out[q, 0], out[q + 1, 1] - out[q, 1])
    return out, -1, length


@njit(cache=True, nogil=True)
def _piece(
    flat: Any, W: int, D: Any, obstacles: Any, margin: int, exempt: int, X0: float, Y0: float,
    has_start: bool, R: float, GX: float, GY: float, has_goal: bool,
) -> tuple[Any, int, Any, int, int, Any, Any, float]:  # fmt: skip
    """:func:`_reach`'s, then the polyline to smooth from (X0, Y0) (or the first cell's center)
    over the cells reached, its vertices' indices, and the squared clearance every point must
    keep (as :func:`~planner.poses.smooth_path` says)."""
    route, n, mask, top, left = _reach(flat, W, D.shape[0], obstacles, margin, exempt)
    cells = route[:n]
    if not has_start:
        X0, Y0 = float(cells[0, 1]), -float(cells[0, 0])
    if not (has_goal and n == flat.shape[0]):  # the goal point only when the piece ends there
        GX, GY = float(cells[n - 1, 1]), -float(cells[n - 1, 0])
    V, index, least, _, _ = _vertices(cells, D, X0, Y0, GX, GY)
    bound = max(least - 1.0, 0.0) if math.isfinite(least) else 0.0
    T = max(bound * bound * (1.0 - _TIE), R * R + _TIE * max(1.0, R * R), _SQUARE + _TIE)
    return route, n, mask, top, left, V, index, T


def poses_ahead(
    route: npt.NDArray[np.int64],
    distance: npt.NDArray[np.float32],
    obstacles: npt.NDArray[np.int64],
    *,
    margin: int,
    exempt: int,
    resolution: float,
    origin: tuple[float, float, float],
    robot_radius: float,
    start: tuple[float, float] | None = None,
    start_yaw: float | None = None,
    goal: tuple[float, float] | None = None,
    goal_yaw: float | None = None,
    outside_blocked: bool = True,
) -> tuple[npt.NDArray[np.float64], int, float]:
    """Poses ``(m, 3)`` ``[x, y, yaw]`` in meters along ``route`` from ``start``, how many of
    the route's cells they follow, and their length in meters. They follow the cells the robot
    reaches before a move into a cell within Chebyshev ``margin`` of one of the dynamic
    ``obstacles`` (or diagonally past one), after the first ``exempt`` moves (the move this
    step decided).

    A lean call for a stepping session, which made its arguments: ``route`` a contiguous int64
    array of flat cell indices (``row * width + col`` of ``distance``'s shape), each a move from
    the last, over traversable cells; ``distance`` a plan's ``analysis.clearance`` (float32);
    ``obstacles`` ``(k, 2)`` int64 cells; ``start`` a point in meters within the first cell
    (default its center), ``start_yaw`` the robot's heading; ``goal`` (a point in meters within
    the route's last cell) and ``goal_yaw``: where the poses end, and with what heading (turning
    in place there), when they follow the whole route.

    The poses keep :func:`~planner.poses.smooth_path`'s rules over the cells they follow (at
    most one cell apart, the yaw the tangent turning at most 15 degrees a pose, a turn in place
    only at the start from ``start_yaw``, every point of their polyline more than the radius
    and at least the route's least clearance less one cell from every blocked cell's center),
    and their polyline enters no blocked cell. They end at the last cell's center (or ``goal``,
    when they follow the whole route and the way there from that center is clear); one pose
    when the robot reaches no other cell. When the start point itself is too near a wall for the
    radius (a robot pushed off its route), the poses lead straight to its cell's center first,
    and turn there in place.
    """
    D = distance
    H, W = D.shape
    res = resolution
    ox, oy, oyaw = origin
    X0, Y0 = _cells(start, H, res, origin) if start is not None else (0.0, 0.0)
    GX, GY = _cells(goal, H, res, origin) if goal is not None else (0.0, 0.0)
    has_yaw = start_yaw is not None
    yaw0 = 0.0 if start_yaw is None else float(start_yaw)
    R = robot_radius / res
    cells, n, mask, top, left, V, index, T = _piece(
        route, W, D, obstacles, margin, exempt, X0, Y0, start is not None, R, GX, GY,
        goal is not None,
    )  # fmt: skip
    to_goal = goal is not None and n == len(route) and index[-1] == n + 1
    if n == 1 and not to_goal:  # the robot waits (or is at the goal): one pose, where it is
        if not has_yaw:
            ahead = cells[1] - cells[0] if cells.shape[0] > 1 else np.zeros(2)
            yaw0 = math.atan2(-float(ahead[0]), float(ahead[1])) + oyaw
        return _hold(start, V[0], H, res, origin, yaw0), 1, 0.0
    sx, sy = start if start is not None else (0.0, 0.0)
    args: _Fixed = (T, math.sqrt(T), mask, top, left, res, ox, oy, oyaw)
    poses, bad, length = _ahead(
        D, outside_blocked, V, *args, yaw0, has_yaw, sx, sy, start is not None
    )
    if bad >= 0:
        return _fallback(D, outside_blocked, V, index, n, args, start, yaw0, has_yaw, H, origin)
    if to_goal and goal is not None:  # ends at the goal point
        poses[-1, 0], poses[-1, 1] = goal  # to the bit
        if goal_yaw is not None:
            poses = _turn_to(poses, goal_yaw)
    return poses, n, length


def _turn_to(poses: npt.NDArray[np.float64], yaw: float) -> npt.NDArray[np.float64]:
    """The poses, then a turn in place at the last one to ``yaw``, at most 15 degrees a pose."""
    last = float(poses[-1, 2])
    fan = _fan_steps(last, yaw)
    if fan == 0:
        poses[-1, 2] = yaw if -math.pi < yaw <= math.pi else _wrap(yaw)
        return poses
    turn = np.empty((fan, 3))
    turn[:, :2] = poses[-1, :2]
    d = _wrap(yaw - last)
    turn[:, 2] = [_wrap(last + d * q / fan) for q in range(1, fan + 1)]
    if -math.pi < yaw <= math.pi:
        turn[-1, 2] = yaw
    return np.concatenate((poses, turn))


def _cells(
    point: tuple[float, float], H: int, res: float, origin: tuple[float, float, float]
) -> tuple[float, float]:
    """A point in meters in cells: X = col, Y = -row (cell centers at whole numbers)."""
    ox, oy, oyaw = origin
    cos_o, sin_o = math.cos(oyaw), math.sin(oyaw)
    du, dv = point[0] - ox, point[1] - oy
    return (cos_o * du + sin_o * dv) / res - 0.5, (-sin_o * du + cos_o * dv) / res - H + 0.5


def _fallback(
    D: npt.NDArray[np.float32],
    outside: bool,
    V: npt.NDArray[np.float64],
    index: npt.NDArray[np.int64],
    n: int,
    args: _Fixed,
    start: tuple[float, float] | None,
    yaw0: float,
    has_yaw: bool,
    H: int,
    origin: tuple[float, float, float],
) -> tuple[npt.NDArray[np.float64], int, float]:
    """The poses when a step of the polyline is not clear: from a start point too near a wall,
    straight to its cell's center first; a step of the route itself (not a session's route),
    only as far as it is clear."""
    res, oyaw = args[5], origin[2]
    lead = np.empty((0, 3))
    poses, bad, length = np.empty((0, 3)), 0, 0.0
    if start is not None and V.shape[0] > 1:
        d = _wrap(math.atan2(V[1, 1] - V[0, 1], V[1, 0] - V[0, 0]) + oyaw)
        fan = _fan_steps(yaw0, d) if has_yaw else 0
        lead = np.empty((fan + 1, 3))
        lead[:, 0], lead[:, 1] = start
        lead[:, 2] = [_wrap(yaw0 + _wrap(d - yaw0) * q / fan) for q in range(fan)] + [d]
        if has_yaw and -math.pi < yaw0 <= math.pi:
            lead[0, 2] = yaw0
        V, index, yaw0, has_yaw = V[1:], index[1:], d, True
        poses, bad, length = _ahead(D, outside, V, *args, yaw0, has_yaw, 0.0, 0.0, False)
    else:
        poses, bad, length = _ahead(D, outside, V, *args, yaw0, has_yaw, 0.0, 0.0, False)
    while bad > 0:  # a step of the route itself not clear: only as far as it is
        n = min(n, int(index[bad]))
        V, index = V[: bad + 1], index[: bad + 1]
        poses, bad, length = _ahead(D, outside, V, *args, yaw0, has_yaw, 0.0, 0.0, False)
    if bad == 0:  # not even the first step is clear: where it is
        poses, n, length = _hold(None, V[0], H, res, origin, yaw0), 1, 0.0
    if lead.shape[0]:
        length += math.hypot(poses[0, 0] - lead[0, 0], poses[0, 1] - lead[0, 1])
        poses = np.concatenate((lead, poses))
    return poses, n, length


def _hold(
    start: tuple[float, float] | None,
    vertex: npt.NDArray[np.float64],
    H: int,
    res: float,
    origin: tuple[float, float, float],
    yaw: float,
) -> npt.NDArray[np.float64]:
    """One pose: at ``start``, else at the vertex (cells) in meters."""
    if start is not None:
        x, y = start
    else:
        ox, oy, oyaw = origin
        u, v = (vertex[0] + 0.5) * res, (H - 0.5 + vertex[1]) * res
        x = ox + math.cos(oyaw) * u - math.sin(oyaw) * v
        y = oy + math.sin(oyaw) * u + math.cos(oyaw) * v
    if not -math.pi < yaw <= math.pi:
        yaw = _wrap(yaw)
    return np.array([[x, y, yaw]])

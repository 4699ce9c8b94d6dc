"""Poses along a piece of route the caller chose (a stepping robot's, from its point): as far as
it is clear of this step's dynamic obstacles, by the rules of :func:`~planner.poses.smooth_path`,
entering no cell the obstacles block. Which cells the route holds, and how far it goes, is
:mod:`planner.stepping.horizon`'s job.

The smoothing is :func:`~planner.poses.polyline.poses_along` (the greedy line-of-sight shortcut,
corners rounded by the widest clear arcs, resampled at most one cell apart), with one more test
on every segment and arc: it enters no blocked cell's square. Those cells are a small window's
mask (:func:`~planner.poses.blocked.window`), from the obstacles' cells and their margin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from planner.poses.blocked import window
from planner.poses.clearance import Sight, threshold
from planner.poses.polyline import Setting, polyline_of, poses_along, turn_steps, wrap_angle

__all__ = ["poses_ahead"]

_HALVINGS = 6  # of a corner's tangent length while its arc is not clear (a plan's poses: 10)


@dataclass(frozen=True, slots=True)
class _Piece:
    """What the poses of one piece of the route are smoothed with besides the polyline and
    the start's heading: the distances, the mask of the blocked cells (empty when none is near:
    the plan's own shortcut, faster along corridors) and what a segment must keep."""

    D: npt.NDArray[np.float32]
    mask: npt.NDArray[np.uint8]
    sight: Sight
    res: float
    origin: tuple[float, float, float]


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
    oyaw = origin[2]
    X0, Y0 = _cells(start, H, res, origin) if start is not None else (0.0, 0.0)
    GX, GY = _cells(goal, H, res, origin) if goal is not None else (0.0, 0.0)
    has_yaw = start_yaw is not None
    yaw0 = 0.0 if start_yaw is None else float(start_yaw)
    cells, n, mask, top, left = window(route, (H, W), obstacles, margin=margin, exempt=exempt)
    if start is None:
        X0, Y0 = float(cells[0, 1]), -float(cells[0, 0])
    if not (goal is not None and n == len(route)):  # the goal point only when the piece ends there
        GX, GY = float(cells[n - 1, 1]), -float(cells[n - 1, 0])
    V, index, least, _, _ = polyline_of(np.ascontiguousarray(cells[:n]), D, (X0, Y0, GX, GY))
    T = threshold(least, robot_radius / res)[1]
    to_goal = goal is not None and n == len(route) and index[-1] == n + 1
    if n == 1 and not to_goal:  # the robot waits (or is at the goal): one pose, where it is
        if not has_yaw:
            ahead = cells[1] - cells[0] if cells.shape[0] > 1 else np.zeros(2)
            yaw0 = math.atan2(-float(ahead[0]), float(ahead[1])) + oyaw
        return _hold(start, V[0], H, res, origin, yaw0), 1, 0.0
    # An arc near a corner keeps the static clearance, not necessarily out of the blocked
    # cells: with a mask, each is checked whatever its size.
    shown = mask if mask.any() else np.zeros((0, 0), dtype=np.uint8)
    piece = _Piece(D, shown, Sight(T, math.sqrt(T), bool(outside_blocked), top, left), res, origin)
    poses, bad, length = _ahead(piece, V, yaw0, has_yaw, start)
    if bad >= 0:
        return _fallback(piece, V, index, n, start, yaw0, has_yaw)
    if to_goal and goal is not None:  # ends at the goal point
        poses[-1, 0], poses[-1, 1] = goal  # to the bit
        if goal_yaw is not None:
            poses = _turn_to(poses, goal_yaw)
    return poses, n, length


def _turn_to(poses: npt.NDArray[np.float64], yaw: float) -> npt.NDArray[np.float64]:
    """The poses, then a turn in place at the last one to ``yaw``, at most 15 degrees a pose."""
    last = float(poses[-1, 2])
    fan = turn_steps(last, yaw)
    if fan == 0:
        poses[-1, 2] = yaw if -math.pi < yaw <= math.pi else wrap_angle(yaw)
        return poses
    turn = np.empty((fan, 3))
    turn[:, :2] = poses[-1, :2]
    d = wrap_angle(yaw - last)
    turn[:, 2] = [wrap_angle(last + d * q / fan) for q in range(1, fan + 1)]
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


def _ahead(
    piece: _Piece,
    V: npt.NDArray[np.float64],
    start_yaw: float,
    has_start_yaw: bool,
    start: tuple[float, float] | None,
) -> tuple[npt.NDArray[np.float64], int, float]:
    """Poses along the polyline V (cells) as :func:`~planner.poses.smooth_path` makes them with
    no goal yaw, clear of the piece's mask too; -1, or the index of a step of V that is not
    clear (then no poses); and their length in meters. The poses at V's first vertex stand at
    ``start`` to the bit, and the first yaw is ``start_yaw`` to the bit when in (-pi, pi]."""
    ox, oy, oyaw = piece.origin
    setting = Setting(
        _HALVINGS, True, piece.res, ox, oy, oyaw, start_yaw, has_start_yaw, 0.0, False
    )  # fmt: skip
    out, bad, n_start, length = poses_along(piece.D, V, piece.mask, piece.sight, setting)
    if bad >= 0:
        return out, bad, 0.0
    if start is not None:
        out[: n_start + 1, 0], out[: n_start + 1, 1] = start
    if has_start_yaw and -math.pi < start_yaw <= math.pi:
        out[0, 2] = start_yaw
    return out, -1, length


def _fallback(
    piece: _Piece,
    V: npt.NDArray[np.float64],
    index: npt.NDArray[np.int64],
    n: int,
    start: tuple[float, float] | None,
    yaw0: float,
    has_yaw: bool,
) -> tuple[npt.NDArray[np.float64], int, float]:
    """The poses when a step of the polyline is not clear: from a start point too near a wall,
    straight to its cell's center first; a step of the route itself (not a session's route),
    only as far as it is clear."""
    res, oyaw, H = piece.res, piece.origin[2], piece.D.shape[0]
    lead = np.empty((0, 3))
    if start is not None and V.shape[0] > 1:
        d = wrap_angle(math.atan2(V[1, 1] - V[0, 1], V[1, 0] - V[0, 0]) + oyaw)
        fan = turn_steps(yaw0, d) if has_yaw else 0
        lead = np.empty((fan + 1, 3))
        lead[:, 0], lead[:, 1] = start
        lead[:, 2] = [wrap_angle(yaw0 + wrap_angle(d - yaw0) * q / fan) for q in range(fan)] + [d]
        if has_yaw and -math.pi < yaw0 <= math.pi:
            lead[0, 2] = yaw0
        V, index, yaw0, has_yaw = V[1:], index[1:], d, True
    poses, bad, length = _ahead(piece, V, yaw0, has_yaw, None)
    while bad > 0:  # a step of the route itself not clear: only as far as it is
        n = min(n, int(index[bad]))
        V, index = V[: bad + 1], index[: bad + 1]
        poses, bad, length = _ahead(piece, V, yaw0, has_yaw, None)
    if bad == 0:  # not even the first step is clear: where it is
        poses, n, length = _hold(None, V[0], H, res, piece.origin, yaw0), 1, 0.0
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
        yaw = wrap_angle(yaw)
    return np.array([[x, y, yaw]])

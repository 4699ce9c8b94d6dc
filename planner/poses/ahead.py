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

from planner.poses.smooth import (
    _BISECT,
    _D_REL,
    _SHORT,
    _SQUARE,
    _STEP,
    _TIE,
    _arc,
    _arc_steps,
    _fan_steps,
    _segment_clear,
    _vertices,
    _wrap,
)

__all__ = ["poses_ahead"]

_INSIDE = 1e-9  # cells: a segment along a blocked cell's side or through its corner enters none


@njit(cache=True, nogil=True)
def _window(
    obstacles: Any, margin: int, top: int, left: int, h: int, w: int, route: Any, exempt: int
) -> Any:
    """The cells within Chebyshev ``margin`` of an obstacle, in the h x w window at (top,
    left) (1: blocked), less the route's first ``exempt`` cells (where the robot is, and the
    cell this step moves it to: the decision already took that move)."""
    mask = np.zeros((h, w), dtype=np.uint8)
    for j in range(obstacles.shape[0]):
        r0 = max(obstacles[j, 0] - margin - top, 0)
        r1 = min(obstacles[j, 0] + margin - top, h - 1)
        c0 = max(obstacles[j, 1] - margin - left, 0)
        c1 = min(obstacles[j, 1] + margin - left, w - 1)
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                mask[r, c] = 1
    for i in range(min(exempt, route.shape[0])):
        mask[route[i, 0] - top, route[i, 1] - left] = 0
    return mask


@njit(cache=True, nogil=True)
def _clear_prefix(route: Any, mask: Any, top: int, left: int, exempt: int) -> int:
    """How many of the route's cells the robot reaches before a move into a blocked cell, or a
    diagonal one past a blocked cell beside it (as a decision refuses), after the first
    ``exempt`` moves."""
    n: int = route.shape[0]
    for i in range(max(exempt, 0) + 1, n):
        r, c = route[i, 0] - top, route[i, 1] - left
        pr, pc = route[i - 1, 0] - top, route[i - 1, 1] - left
        if mask[r, c] or (r != pr and c != pc and (mask[pr, c] or mask[r, pc])):
            return i
    return n


@njit(cache=True, nogil=True)
def _free(mask: Any, top: int, left: int, ax: float, ay: float, bx: float, by: float) -> bool:
    """Whether segment a-b (X = col, Y = -row) enters no blocked cell's square: column by
    column, the rows its part in the column spans."""
    # u, v: the cells' corners at whole numbers, cell (r, c) = [c, c + 1] x [r, r + 1].
    au, av, bu, bv = ax + 0.5, -ay + 0.5, bx + 0.5, -by + 0.5
    h, w = mask.shape
    du, dv = bu - au, bv - av
    u_lo, u_hi = min(au, bu), max(au, bu)
    for c in range(math.floor(u_lo), math.floor(u_hi) + 1):
        u0 = max(u_lo, c + _INSIDE)
        u1 = min(u_hi, c + 1 - _INSIDE)
        if u0 > u1:
            continue
        if abs(du) > 1e-12:
            v0 = av + dv * (u0 - au) / du
            v1 = av + dv * (u1 - au) / du
        else:
            v0, v1 = av, bv
        v_lo, v_hi = min(v0, v1), max(v0, v1)
        cc = c - left
        if cc < 0 or cc >= w:
            continue
        for r in range(math.ceil(v_lo - 1 + _INSIDE), math.floor(v_hi - _INSIDE) + 1):
            rr = r - top
            if 0 <= rr < h and mask[rr, cc]:
                return False
    return True


@njit(cache=True, nogil=True)
def _clear(
    D: Any, outside: bool, T: float, root: float, mask: Any, top: int, left: int,
    ax: float, ay: float, bx: float, by: float,
) -> bool:  # fmt: skip
    if not _free(mask, top, left, ax, ay, bx, by):
        return False
    return _segment_clear(D, outside, ax, ay, bx, by, T, root)


@njit(cache=True, nogil=True)
def _arc_clear(
    D: Any, outside: bool, pts: Any, T: float, root: float, mask: Any, top: int, left: int
) -> bool:
    for q in range(pts.shape[0] - 1):
        if not _clear(
            D, outside, T, root, mask, top, left, pts[q, 0], pts[q, 1], pts[q + 1, 0],
            pts[q + 1, 1],
        ):  # fmt: skip
            return False
    return True


@njit(cache=True, nogil=True)
def _shortcut(
    D: Any, outside: bool, V: Any, T: float, root: float, mask: Any, top: int, left: int
) -> tuple[Any, int]:
    """The greedy line-of-sight shortcut of V (as :mod:`planner.poses.smooth`'s), each line
    entering no blocked cell either; -1, or the index of a vertex whose step is not clear."""
    n = V.shape[0]
    keep = np.empty(n, dtype=np.int64)
    keep[0] = 0
    k = 1
    a = 0
    while a < n - 1:
        ax, ay = V[a, 0], V[a, 1]
        j = a + 1
        if not _clear(D, outside, T, root, mask, top, left, ax, ay, V[j, 0], V[j, 1]):
            return keep[:k], a
        while j + 1 < n:
            bx, by = V[j + 1, 0], V[j + 1, 1]
            if not _clear(D, outside, T, root, mask, top, left, ax, ay, bx, by):
                break
            j += 1
        keep[k] = j
        k += 1
        a = j
    return keep[:k], -1


@njit(cache=True, nogil=True)
def _ahead(
    D: Any,
    outside: bool,
    V: Any,
    T: float,
    root: float,
    mask: Any,
    top: int,
    left: int,
    res: float,
    ox: float,
    oy: float,
    oyaw: float,
    start_yaw: float,
    has_start_yaw: bool,
) -> tuple[Any, int]:
    """Poses (m, 3) x, y, yaw in meters along the polyline V (cells, X = col, Y = -row), as
    ``smooth._smooth`` makes them with no goal yaw, clear of ``mask`` too; and -1, or the index
    of a step of V that is not clear (then no poses)."""
    H = D.shape[0]
    keep, bad = _shortcut(D, outside, V, T, root, mask, top, left)
    if bad >= 0:
        return np.empty((0, 3)), bad
    P = V[keep]
    k = P.shape[0]
    nseg = max(k - 1, 0)
    L = np.empty(nseg)
    U = np.empty((nseg, 2))
    for i in range(nseg):
        dx = P[i + 1, 0] - P[i, 0]
        dy = P[i + 1, 1] - P[i, 1]
        L[i] = math.hypot(dx, dy)
        U[i, 0] = dx / L[i]
        U[i, 1] = dy / L[i]
    tang = np.zeros(k)
    turn = np.zeros(k)
    for i in range(1, k - 1):
        ix, iy, ux, uy = U[i - 1, 0], U[i - 1, 1], U[i, 0], U[i, 1]
        theta = math.atan2(ix * uy - iy * ux, ix * ux + iy * uy)
        if abs(theta) < 1e-9:
            continue
        theta = max(min(theta, math.pi - 1e-6), -math.pi + 1e-6)
        turn[i] = theta
        t_max = min(L[i - 1] if i == 1 else L[i - 1] / 2.0, L[i] if i == k - 2 else L[i] / 2.0)
        # An arc near the corner keeps the static clearance (the corner is a cell center), not
        # necessarily out of the blocked cells: it is checked whatever its size.
        corner = D[round(-P[i, 1]), round(P[i, 0])] * (1.0 - _D_REL)
        safe = min(max(corner - root - 1e-9, 0.0), t_max)
        lo = 0.0
        if _arc_clear(
            D, outside, _arc(P[i, 0], P[i, 1], ix, iy, ux, uy, theta, t_max), T, root, mask, top,
            left,
        ):  # fmt: skip
            lo = t_max
        else:
            hi = t_max
            for _ in range(_BISECT):
                mid = 0.5 * (lo + hi)
                pts = _arc(P[i, 0], P[i, 1], ix, iy, ux, uy, theta, mid)
                if _arc_clear(D, outside, pts, T, root, mask, top, left):
                    lo = mid
                else:
                    hi = mid
            short = t_max - _SHORT
            if lo > short and _arc_clear(
                D, outside, _arc(P[i, 0], P[i, 1], ix, iy, ux, uy, theta, short), T, root, mask,
                top, left,
            ):  # fmt: skip
                lo = short
        if lo == 0.0:
            # Within its cell (a route cell, not blocked) and the static bound: always clear.
            small = min(safe, 0.45, t_max - _SHORT)
            if small > 0.0 and _arc_clear(
                D, outside, _arc(P[i, 0], P[i, 1], ix, iy, ux, uy, theta, small), T, root, mask,
                top, left,
            ):  # fmt: skip
                lo = small
        tang[i] = lo
    first_yaw = math.atan2(U[0, 1], U[0, 0]) + oyaw if nseg > 0 else start_yaw
    if nseg == 0 and not has_start_yaw:
        first_yaw = oyaw
    last_yaw = math.atan2(U[nseg - 1, 1], U[nseg - 1, 0]) + oyaw if nseg > 0 else first_yaw
    n_start = _fan_steps(start_yaw, first_yaw) if has_start_yaw else 0
    count = n_start + 1
    for i in range(nseg):
        line = L[i] - tang[i] - tang[i + 1]
        if line > 1e-9:
            count += math.ceil(line / _STEP)
        if i + 1 < k - 1 and tang[i + 1] > 0.0:
            rho = tang[i + 1] / math.tan(abs(turn[i + 1]) / 2.0)
            count += _arc_steps(turn[i + 1], rho)
    out = np.empty((count, 3))
    cos_o = math.cos(oyaw)
    sin_o = math.sin(oyaw)
    n = 0
    if has_start_yaw:
        d = _wrap(first_yaw - start_yaw)
        for q in range(n_start):
            out[n, 2] = start_yaw + d * q / n_start
            n += 1
    for i in range(nseg):
        ax = P[i, 0] + U[i, 0] * tang[i]
        ay = P[i, 1] + U[i, 1] * tang[i]
        line = L[i] - tang[i] - tang[i + 1]
        yaw = math.atan2(U[i, 1], U[i, 0]) + oyaw
        if line > 1e-9:
            m = math.ceil(line / _STEP)
            for q in range(m):
                out[n, 0] = ax + U[i, 0] * line * q / m
                out[n, 1] = ay + U[i, 1] * line * q / m
                out[n, 2] = yaw
                n += 1
        if i + 1 < k - 1 and tang[i + 1] > 0.0:
            c = i + 1
            pts = _arc(P[c, 0], P[c, 1], U[i, 0], U[i, 1], U[c, 0], U[c, 1], turn[c], tang[c])
            for q in range(pts.shape[0] - 1):
                out[n, 0] = pts[q, 0]
                out[n, 1] = pts[q, 1]
                out[n, 2] = pts[q, 2] + oyaw
                n += 1
    out[n, 0] = P[k - 1, 0]
    out[n, 1] = P[k - 1, 1]
    out[n, 2] = last_yaw
    for q in range(count):
        if q < n_start:
            X, Y = P[0, 0], P[0, 1]
        else:
            X, Y = out[q, 0], out[q, 1]
        u = (X + 0.5) * res
        v = (H - 0.5 + Y) * res
        out[q, 0] = ox + cos_o * u - sin_o * v
        out[q, 1] = oy + sin_o * u + cos_o * v
        out[q, 2] = _wrap(out[q, 2])
    return out, -1


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
    outside_blocked: bool = True,
) -> tuple[npt.NDArray[np.float64], int]:
    """Poses ``(m, 3)`` ``[x, y, yaw]`` in meters along ``route`` from ``start``, and how many of
    the route's cells they follow: those the robot reaches before a move into a cell within
    Chebyshev ``margin`` of one of the dynamic ``obstacles`` (or diagonally past one), after the
    first ``exempt`` moves (the move this step decided).

    A lean call for a stepping session, which made its arguments: ``route`` a contiguous
    ``(n, 2)`` int64 array of ``[row, col]`` cells, each a move from the last, over the
    traversable cells; ``distance`` a plan's ``analysis.clearance`` (float32); ``obstacles``
    ``(k, 2)`` int64 cells; ``start`` a point in meters within the first cell (default its
    center), ``start_yaw`` the robot's heading.

    The poses keep :func:`~planner.poses.smooth_path`'s rules over the cells they follow (at
    most one cell apart, the yaw the tangent turning at most 15 degrees a pose, a turn in place
    only at the start from ``start_yaw``, every point of their polyline more than the radius
    and at least the route's least clearance less one cell from every blocked cell's center),
    and their polyline enters no blocked cell. They end at the last cell's center. When the
    start point itself is too near a wall for the radius (a robot pushed off its route), the
    poses lead straight to its cell's center first, and turn there in place.
    """
    D = distance
    H, W = D.shape
    top = max(int(route[:, 0].min()) - 1, 0)
    left = max(int(route[:, 1].min()) - 1, 0)
    h = min(int(route[:, 0].max()) + 2, H) - top
    w = min(int(route[:, 1].max()) + 2, W) - left
    mask = _window(obstacles, margin, top, left, h, w, route, exempt + 1)
    n = int(_clear_prefix(route, mask, top, left, exempt))
    cells = route[:n]
    res = resolution
    ox, oy, oyaw = origin
    cos_o, sin_o = math.cos(oyaw), math.sin(oyaw)
    X0, Y0 = float(cells[0, 1]), float(-cells[0, 0])
    if start is not None:
        du, dv = start[0] - ox, start[1] - oy
        X0 = (cos_o * du + sin_o * dv) / res - 0.5
        Y0 = (-sin_o * du + cos_o * dv) / res - H + 0.5
    has_yaw = start_yaw is not None
    yaw0 = 0.0 if start_yaw is None else float(start_yaw)
    if n == 1:  # the robot waits (or is at the goal): one pose, where it is
        if not has_yaw:
            ahead = route[1] - route[0] if route.shape[0] > 1 else np.zeros(2)
            yaw0 = math.atan2(-float(ahead[0]), float(ahead[1])) + oyaw
        x, y = start if start is not None else _meters(X0, Y0, H, res, ox, oy, cos_o, sin_o)
        return np.array([[x, y, _wrap(yaw0)]]), 1
    last = (float(cells[-1, 1]), float(-cells[-1, 0]))
    V, index, least, _, _ = _vertices(cells, D, X0, Y0, last[0], last[1])
    bound = max(least - 1.0, 0.0) if math.isfinite(least) else 0.0
    R = robot_radius / res
    T = max(bound * bound * (1.0 - _TIE), R * R + _TIE * max(1.0, R * R), _SQUARE + _TIE)
    args = (T, math.sqrt(T), mask, top, left, res, ox, oy, oyaw)
    poses, bad = _ahead(D, outside_blocked, V, *args, yaw0, has_yaw)
    lead = np.empty((0, 3))
    if bad == 0 and start is not None:
        # Too near a wall at the point: straight to the first cell's center, then on from there.
        d = _wrap(math.atan2(V[1, 1] - V[0, 1], V[1, 0] - V[0, 0]) + oyaw)
        fan = _fan_steps(yaw0, d) if has_yaw else 0
        lead = np.empty((fan + 1, 3))
        lead[:, 0], lead[:, 1] = start
        lead[:, 2] = [_wrap(yaw0 + _wrap(d - yaw0) * q / fan) for q in range(fan)] + [d]
        V, index, yaw0, has_yaw = V[1:], index[1:], d, True
        poses, bad = _ahead(D, outside_blocked, V, *args, yaw0, has_yaw)
    while bad > 0:  # a step of the route itself not clear: only as far as it is
        n = min(n, int(index[bad]))
        V, index = V[: bad + 1], index[: bad + 1]
        poses, bad = _ahead(D, outside_blocked, V, *args, yaw0, has_yaw)
    if bad == 0:  # not even the first step is clear: where it is
        x, y = _meters(V[0, 0], V[0, 1], H, res, ox, oy, cos_o, sin_o)
        poses, n = np.array([[x, y, _wrap(yaw0)]]), 1
    if lead.shape[0]:
        poses = np.concatenate((lead, poses))
    elif start is not None:  # the point as given, to the bit (and its turn in place there)
        there = (poses[:, 0] == poses[0, 0]) & (poses[:, 1] == poses[0, 1])
        run = len(poses) if there.all() else int(np.argmin(there))
        poses[:run, 0], poses[:run, 1] = start
    if start_yaw is not None and -math.pi < start_yaw <= math.pi:
        poses[0, 2] = start_yaw  # the heading as given, to the bit
    out: npt.NDArray[np.float64] = poses
    return out, n


def _meters(
    X: float, Y: float, H: int, res: float, ox: float, oy: float, cos_o: float, sin_o: float
) -> tuple[float, float]:
    u, v = (X + 0.5) * res, (H - 0.5 + Y) * res
    return ox + cos_o * u - sin_o * v, oy + sin_o * u + cos_o * v

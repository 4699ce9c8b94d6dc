"""Polylines into poses: a polyline's segments and corners, the arcs that round them, and the
poses written along lines and arcs at most one cell apart, each with its heading (for the plan's
smoothing and the step's path ahead alike)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

_TURN_STEP = math.radians(14.9)  # below MAX_TURN: rounding never pushes a step over it
_STEP = 0.9999  # cells between consecutive poses at most


@njit(cache=True, nogil=True)
def _arc_steps(theta: float, rho: float) -> int:
    """Chords of an arc turning ``theta`` on radius ``rho``: each turns at most _TURN_STEP and
    is at most _STEP long."""
    step = _TURN_STEP
    if 2.0 * rho > _STEP:
        step = min(step, 2.0 * math.asin(_STEP / (2.0 * rho)))
    return max(1, math.ceil(abs(theta) / step))


@njit(cache=True, nogil=True)
def _arc(
    cx: float, cy: float, ix: float, iy: float, ox: float, oy: float, theta: float, t: float
) -> Any:
    """The fillet of the corner (cx, cy) entered along unit (ix, iy) and left along (ox, oy),
    turning ``theta`` (counter-clockwise positive), tangent ``t`` from the corner: its points
    from the tangent point in to the tangent point out, and its center and radius."""
    rho = t / math.tan(abs(theta) / 2.0)
    m = _arc_steps(theta, rho)
    t1x = cx - ix * t
    t1y = cy - iy * t
    side = 1.0 if theta > 0.0 else -1.0
    Ox = t1x - iy * rho * side
    Oy = t1y + ix * rho * side
    phi0 = math.atan2(t1y - Oy, t1x - Ox)
    pts = np.empty((m + 1, 3))
    for q in range(m + 1):
        phi = phi0 + theta * q / m
        pts[q, 0] = Ox + rho * math.cos(phi)
        pts[q, 1] = Oy + rho * math.sin(phi)
        pts[q, 2] = phi + side * math.pi / 2.0
    pts[0, 0], pts[0, 1] = t1x, t1y
    pts[m, 0], pts[m, 1] = cx + ox * t, cy + oy * t
    pts[0, 2] = math.atan2(iy, ix)
    pts[m, 2] = math.atan2(oy, ox)
    return pts


@njit(cache=True, nogil=True)
def _wrap(a: float) -> float:
    """An angle in (-pi, pi]."""
    a = math.atan2(math.sin(a), math.cos(a))
    return math.pi if a == -math.pi else a


@njit(cache=True, nogil=True)
def _fan_steps(a: float, b: float) -> int:
    """Poses after the first of a turn in place from heading a to heading b."""
    d = abs(_wrap(b - a))
    return math.ceil(d / _TURN_STEP) if d > 1e-12 else 0


@njit(cache=True, nogil=True)
def _segments(P: Any) -> tuple[int, Any, Any]:
    """The number of segments of the polyline P, their lengths and unit directions."""
    nseg = max(P.shape[0] - 1, 0)
    L = np.empty(nseg)
    U = np.empty((nseg, 2))
    for i in range(nseg):
        dx = P[i + 1, 0] - P[i, 0]
        dy = P[i + 1, 1] - P[i, 1]
        L[i] = math.hypot(dx, dy)
        U[i, 0] = dx / L[i]
        U[i, 1] = dy / L[i]
    return nseg, L, U


@njit(cache=True, nogil=True)
def _corner(U: Any, L: Any, i: int, k: int) -> tuple[float, float]:
    """Vertex i's turn (0 for none; held short of a full reversal) and the longest tangent its
    two segments allow an arc there (all of an end segment, half of an inner one)."""
    ix, iy, ux, uy = U[i - 1, 0], U[i - 1, 1], U[i, 0], U[i, 1]
    theta = math.atan2(ix * uy - iy * ux, ix * ux + iy * uy)
    if abs(theta) < 1e-9:
        return 0.0, 0.0
    theta = max(min(theta, math.pi - 1e-6), -math.pi + 1e-6)
    return theta, min(L[i - 1] if i == 1 else L[i - 1] / 2.0, L[i] if i == k - 2 else L[i] / 2.0)


@njit(cache=True, nogil=True)
def _write(
    P: Any, U: Any, L: Any, tang: Any, turn: Any, k: int, nseg: int, res: float, H: int,
    ox: float, oy: float, oyaw: float, start_yaw: float, has_start_yaw: bool, first_yaw: float,
    last_yaw: float, goal_yaw: float, has_goal_yaw: bool,
) -> Any:  # fmt: skip
    """The poses (count, 3) in meters along vertices P (cells, X = col, Y = -row) with unit
    directions U, lengths L, corner tangent lengths ``tang`` and turns ``turn``: the start's
    turn in place (to a given yaw), lines and arcs at most one cell apart, the goal's turn."""
    n_start = _fan_steps(start_yaw, first_yaw) if has_start_yaw else 0
    n_goal = _fan_steps(last_yaw, goal_yaw) if has_goal_yaw else 0
    count = n_start + 1 + n_goal
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
    n += 1
    if has_goal_yaw:
        d = _wrap(goal_yaw - last_yaw)
        for q in range(1, n_goal + 1):
            out[n, 2] = last_yaw + d * q / n_goal
            n += 1
    # Cells to meters: the start's and goal's turns in place stand at their points.
    for q in range(count):
        if q < n_start:
            X, Y = P[0, 0], P[0, 1]
        elif q >= count - n_goal:
            X, Y = P[k - 1, 0], P[k - 1, 1]
        else:
            X, Y = out[q, 0], out[q, 1]
        u = (X + 0.5) * res
        v = (H - 0.5 + Y) * res
        out[q, 0] = ox + cos_o * u - sin_o * v
        out[q, 1] = oy + sin_o * u + cos_o * v
        out[q, 2] = _wrap(out[q, 2])
    return out

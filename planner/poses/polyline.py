"""Polylines into poses: the polyline through a path's cells, its line-of-sight shortcut, its
corners rounded by the widest clear arcs, and the poses written along lines and arcs at most one
cell apart, each with its heading (for the plan's smoothing and the step's path ahead alike).

>>> round(wrap_angle(3 * math.pi / 2), 6), turn_steps(0.0, math.pi / 2)
(-1.570796, 7)
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput, quote
from planner.poses.clearance import D_REL, Sight, chords_clear, shortcut

__all__ = [
    "BLOCKED",
    "JUMP",
    "OUTSIDE",
    "Setting",
    "polyline_of",
    "poses_along",
    "turn_steps",
    "wrap_angle",
]

OUTSIDE, JUMP, BLOCKED = 1, 2, 3
"""What is wrong with a path, as :func:`polyline_of` says: a cell outside the map, a step to a
cell that is not a neighbour, a blocked cell."""

_TURN_STEP = math.radians(14.9)  # below MAX_TURN: rounding never pushes a step over it
_STEP = 0.9999  # cells between consecutive poses at most
_SHORT = 1e-6  # cells: a shorter line than this between two arcs would have no clear direction


class Setting(NamedTuple):
    """How :func:`poses_along` writes poses: ``halvings`` of a corner's tangent while its arc
    is not clear, whether a mask may block arcs within the static bound (``masked``: then each
    is checked whatever its size), the frame (``res`` m a cell, origin ``ox, oy, oyaw``) and the
    headings at the ends (a turn in place from ``start_yaw``, to ``goal_yaw``, when given)."""

    halvings: int
    masked: bool
    res: float
    ox: float
    oy: float
    oyaw: float
    start_yaw: float
    has_start_yaw: bool
    goal_yaw: float
    has_goal_yaw: bool


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
    P: Any, U: Any, L: Any, tang: Any, turn: Any, H: int, s: Setting, yaws: tuple[float, float]
) -> Any:
    """The poses (count, 3) in meters along vertices P (cells, X = col, Y = -row) with unit
    directions U, lengths L, corner tangent lengths ``tang`` and turns ``turn`` on a map H
    cells high: the start's turn in place (to the first of ``yaws``), lines and arcs at most
    one cell apart (the last heading the second of ``yaws``), the goal's turn."""
    k, nseg = P.shape[0], L.shape[0]
    res, ox, oy, oyaw = s.res, s.ox, s.oy, s.oyaw
    start_yaw, has_start_yaw, goal_yaw, has_goal_yaw = (
        s.start_yaw,
        s.has_start_yaw,
        s.goal_yaw,
        s.has_goal_yaw,
    )
    first_yaw, last_yaw = yaws
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


@njit(cache=True, nogil=True)
def _tangents(
    D: Any, mask: Any, P: Any, U: Any, L: Any, sight: Sight, masked: bool, halvings: int
) -> tuple[Any, Any]:
    """Each corner of the polyline P (segments U, L as :func:`_segments` gives them): its
    turn, and the longest tangent its segments allow whose arc is clear (``halvings`` bisections
    while it is not). Within the corner's static bound an arc is clear unless ``masked``: then
    the mask's cells may block it too, and it is checked whatever its size."""
    k = P.shape[0]
    tang = np.zeros(k)
    turn = np.zeros(k)
    root = sight.root
    for i in range(1, k - 1):
        theta, t_max = _corner(U, L, i, k)
        if theta == 0.0:
            continue
        turn[i] = theta
        cx, cy, ix, iy, ux, uy = P[i, 0], P[i, 1], U[i - 1, 0], U[i - 1, 1], U[i, 0], U[i, 1]
        # The corner is a cell center: every point within this of it is clear.
        corner = D[round(-cy), round(cx)] * (1.0 - D_REL)
        safe = min(max(corner - root - 1e-9, 0.0), t_max)
        lo = 0.0 if masked else safe
        if lo < t_max:
            if chords_clear(D, mask, _arc(cx, cy, ix, iy, ux, uy, theta, t_max), sight):
                lo = t_max
            else:
                hi = t_max
                for _ in range(halvings):
                    mid = 0.5 * (lo + hi)
                    pts = _arc(cx, cy, ix, iy, ux, uy, theta, mid)
                    if chords_clear(D, mask, pts, sight):
                        lo = mid
                    else:
                        hi = mid
                # A line left between arcs is either none or long enough to have a direction.
                short = t_max - _SHORT
                if lo > short and (
                    (not masked and short <= safe)
                    or chords_clear(D, mask, _arc(cx, cy, ix, iy, ux, uy, theta, short), sight)
                ):
                    lo = short
        if masked and lo == 0.0:
            # Within its cell (a route cell, not blocked) and the static bound: always clear.
            small = min(safe, 0.45, t_max - _SHORT)
            if small > 0.0 and chords_clear(
                D, mask, _arc(cx, cy, ix, iy, ux, uy, theta, small), sight
            ):
                lo = small
        tang[i] = lo
    return tang, turn


@njit(cache=True, nogil=True)
def _vertices(
    cells: Any, D: Any, ends: tuple[float, float, float, float]
) -> tuple[Any, Any, float, int, int]:
    """The polyline to shortcut: the start point, the cells' centers once each, the goal point
    (``ends``: sx, sy, gx, gy; each end dropped where it is its cell's center), with each
    vertex's index in start, cells, goal; the path's least distance; and what is wrong with
    it, at which cell."""
    sx, sy, gx, gy = ends
    H, W = D.shape
    n = cells.shape[0]
    V = np.empty((n + 2, 2))
    index = np.empty(n + 2, dtype=np.int64)
    least = np.inf
    k = 0
    for i in range(n):
        r, c = cells[i, 0], cells[i, 1]
        if r < 0 or r >= H or c < 0 or c >= W:
            return V[:0], index[:0], least, OUTSIDE, i
        if i > 0 and max(abs(r - cells[i - 1, 0]), abs(c - cells[i - 1, 1])) > 1:
            return V[:0], index[:0], least, JUMP, i - 1
        if D[r, c] <= 0.0:
            return V[:0], index[:0], least, BLOCKED, i
        least = min(least, float(D[r, c]))
        X, Y = float(c), -float(r)
        if i == 0 and (sx != X or sy != Y):
            V[0, 0], V[0, 1], index[0] = sx, sy, 0
            k = 1
        if k == 0 or i == 0 or V[k - 1, 0] != X or V[k - 1, 1] != Y:
            V[k, 0], V[k, 1], index[k] = X, Y, i + 1
            k += 1
    if gx != V[k - 1, 0] or gy != V[k - 1, 1]:
        V[k, 0], V[k, 1], index[k] = gx, gy, n + 1
        k += 1
    return V[:k], index[:k], least, 0, -1


@njit(cache=True, nogil=True)
def _poses(D: Any, mask: Any, P: Any, sight: Sight, s: Setting) -> tuple[Any, int, float]:
    """Poses (m, 3) x, y, yaw in meters along the shortcut P (cells, X = col, Y = -row), clear
    of ``mask`` too; how many poses the start's turn in place takes before the first; and the
    poses' length in meters."""
    nseg, L, U = _segments(P)
    # Round each corner: the longest tangent its segments allow whose arc is clear.
    tang, turn = _tangents(D, mask, P, U, L, sight, s.masked, s.halvings)
    # Count, then write the poses: the start's turn in place, lines and arcs, the goal's.
    first_yaw = math.atan2(U[0, 1], U[0, 0]) + s.oyaw if nseg > 0 else s.start_yaw
    if nseg == 0 and not s.has_start_yaw:
        first_yaw = s.goal_yaw if s.has_goal_yaw else s.oyaw
    last_yaw = math.atan2(U[nseg - 1, 1], U[nseg - 1, 0]) + s.oyaw if nseg > 0 else first_yaw
    out = _write(P, U, L, tang, turn, D.shape[0], s, (first_yaw, last_yaw))
    n_start = _fan_steps(s.start_yaw, first_yaw) if s.has_start_yaw else 0
    length = 0.0
    for q in range(out.shape[0] - 1):
        length += math.hypot(out[q + 1, 0] - out[q, 0], out[q + 1, 1] - out[q, 1])
    return out, n_start, length


# --------------------------------------------------------------------------------------------
# The wrappers


def polyline_of(
    cells: npt.NDArray[np.int64],
    distance: npt.NDArray[np.float32],
    ends: tuple[float, float, float, float],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], float, int, int]:
    """The polyline through a path's ``cells`` ``(n, 2)`` (int64 ``[row, col]``) from the start
    point to the goal point (``ends``: their X, Y in cells; X = col, Y = -row) that its poses
    follow, before the shortcut: ``(V, index, least, wrong, at)``, the vertices, each one's
    index in start, cells, goal, the path's least ``distance``, and what is wrong with the path
    (0, or :data:`OUTSIDE`, :data:`JUMP`, :data:`BLOCKED`) at which cell (see ``_vertices``)."""
    if not isinstance(cells, np.ndarray) or cells.dtype != np.int64 or cells.ndim != 2:
        raise InvalidInput(
            f"cells must be an (n, 2) int64 array; got {quote(cells)}", field="cells"
        )
    if cells.shape[1:] != (2,) or len(cells) == 0 or not cells.flags.c_contiguous:
        msg = f"cells must be a contiguous (n, 2) array, n >= 1; got shape {cells.shape!r}"
        raise InvalidInput(msg, field="cells")
    _distance(distance)
    point = tuple(float(v) for v in ends)
    if len(point) != 4 or not all(math.isfinite(v) for v in point):
        raise InvalidInput(f"ends must be 4 finite numbers; got {quote(ends)}", field="ends")
    V, index, least, wrong, at = _vertices(cells, distance, point)
    return V, index, float(least), int(wrong), int(at)


def poses_along(
    distance: npt.NDArray[np.float32],
    polyline: npt.NDArray[np.float64],
    mask: npt.NDArray[np.uint8],
    sight: Sight,
    setting: Setting,
) -> tuple[npt.NDArray[np.float64], int, int, float]:
    """Poses ``(m, 3)`` ``[x, y, yaw]`` in meters along ``polyline`` (cells, as
    :func:`polyline_of` gives it): its line-of-sight shortcut clear by ``sight`` (see
    :func:`~planner.poses.clearance.shortcut`), corners rounded by the widest clear arcs, written
    by ``setting``. Returns the poses, -1 (or the index of a vertex whose step to the next is
    not clear: then no poses), how many poses the start's turn in place takes before the first,
    and the poses' length in meters."""
    _distance(distance)
    keep, bad = shortcut(distance, polyline, mask, sight)
    if bad >= 0:
        return np.empty((0, 3)), bad, 0, 0.0
    halvings, masked, *rest = setting
    numbers = [float(v) for v in rest]
    if not all(math.isfinite(v) for v in numbers) or numbers[0] <= 0:
        raise InvalidInput(
            f"setting must be finite, res > 0; got {quote(setting)}", field="setting"
        )
    res, ox, oy, oyaw, start_yaw, has_start, goal_yaw, has_goal = numbers
    s = Setting(
        int(halvings), bool(masked), res, ox, oy, oyaw, start_yaw, bool(has_start), goal_yaw,
        bool(has_goal),
    )  # fmt: skip
    out, n_start, length = _poses(distance, mask, polyline[keep], sight, s)
    return out, -1, int(n_start), float(length)


def wrap_angle(angle: float) -> float:
    """``angle`` (radians, finite) in (-pi, pi]."""
    return float(_wrap(_finite(angle, "angle")))


def turn_steps(start: float, end: float) -> int:
    """Poses after the first of a turn in place from heading ``start`` to ``end`` (radians),
    each turning at most 14.9 degrees."""
    return int(_fan_steps(_finite(start, "start"), _finite(end, "end")))


def _finite(value: float, field: str) -> float:
    out = float(value)
    if not math.isfinite(out):
        raise InvalidInput(f"{field} must be a finite number; got {quote(value)}", field=field)
    return out


def _distance(distance: Any) -> None:
    if not (
        isinstance(distance, np.ndarray)
        and distance.dtype == np.float32
        and distance.ndim == 2
        and distance.size
        and distance.flags.c_contiguous
    ):
        msg = f"distance must be a contiguous 2-D float32 array; got {quote(distance)}"
        raise InvalidInput(msg, field="distance")

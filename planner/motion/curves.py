"""Shortest paths of a car with a bounded turning radius and no obstacles: Reeds-Shepp (forward
and reverse, Reeds & Shepp 1990, the 48 words in OMPL's formulation) and Dubins (forward
only). The hybrid search expands toward the goal along them and takes their length as a
heuristic.

A path is up to five segments, each a code (``LEFT``, ``STRAIGHT``, ``RIGHT``) and a signed
length in units of the turning radius (an angle for a turn; negative: in reverse).

>>> import math
>>> path = reeds_shepp((0.0, 0.0, 0.0), (0.0, 0.0, math.pi), 1.0)
>>> round(path.length, 4), path.cusps
(3.1416, 2)
>>> round(dubins((0.0, 0.0, 0.0), (4.0, 0.0, 0.0), 1.0).length, 6)
4.0
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput

__all__ = [
    "LEFT",
    "RIGHT",
    "STRAIGHT",
    "Curve",
    "curve_codes",
    "dubins",
    "reeds_shepp",
    "sample_curve",
    "sample_segments",
    "shortest_curve",
]

LEFT, STRAIGHT, RIGHT, NONE = 0, 1, 2, 3
_ZERO = 1e-10
_PI = math.pi
_HALF_PI = math.pi / 2

_RS_TYPES = np.array(
    [
        [0, 2, 0, 3, 3], [2, 0, 2, 3, 3], [0, 2, 0, 2, 3], [2, 0, 2, 0, 3], [0, 2, 1, 0, 3],
        [2, 0, 1, 2, 3], [0, 1, 2, 0, 3], [2, 1, 0, 2, 3], [0, 2, 1, 2, 3], [2, 0, 1, 0, 3],
        [2, 1, 2, 0, 3], [0, 1, 0, 2, 3], [0, 1, 2, 3, 3], [2, 1, 0, 3, 3], [0, 1, 0, 3, 3],
        [2, 1, 2, 3, 3], [0, 2, 1, 0, 2], [2, 0, 1, 2, 0],
    ],
    dtype=np.int64,
)  # fmt: skip
"""OMPL's 18 Reeds-Shepp path types (L, S, R; 3: none)."""

_DUBINS_TYPES = np.array(
    [[0, 1, 0], [2, 1, 2], [0, 1, 2], [2, 1, 0], [2, 0, 2], [0, 2, 0]], dtype=np.int64
)
"""LSL, RSR, LSR, RSL, RLR, LRL."""


@njit(cache=True, nogil=True)
def _mod2pi(x: float) -> float:
    v = np.fmod(x, 2.0 * _PI)
    if v < -_PI:
        v += 2.0 * _PI
    elif v > _PI:
        v -= 2.0 * _PI
    return v


@njit(cache=True, nogil=True)
def _polar(x: float, y: float) -> tuple[float, float]:
    return math.sqrt(x * x + y * y), math.atan2(y, x)


@njit(cache=True, nogil=True)
def _tau_omega(u: float, v: float, xi: float, eta: float, phi: float) -> tuple[float, float]:
    delta = _mod2pi(u - v)
    A = math.sin(u) - math.sin(delta)
    B = math.cos(u) - math.cos(delta) - 1.0
    t1 = math.atan2(eta * A - xi * B, xi * A + eta * B)
    t2 = 2.0 * (math.cos(delta) - math.cos(v) - math.cos(u)) + 3.0
    tau = _mod2pi(t1 + _PI) if t2 < 0 else _mod2pi(t1)
    return tau, _mod2pi(tau - u + v - phi)


@njit(cache=True, nogil=True)
def _lsl(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    u, t = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    if t >= -_ZERO:
        v = _mod2pi(phi - t)
        if v >= -_ZERO:
            return True, t, u, v
    return False, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _lsr(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    u1, t1 = _polar(x + math.sin(phi), y - 1.0 - math.cos(phi))
    u1 = u1 * u1
    if u1 >= 4.0:
        u = math.sqrt(u1 - 4.0)
        t = _mod2pi(t1 + math.atan2(2.0, u))
        v = _mod2pi(t - phi)
        if t >= -_ZERO and v >= -_ZERO:
            return True, t, u, v
    return False, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _lrl(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    u1, theta = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    if u1 <= 4.0:
        u = -2.0 * math.asin(0.25 * u1)
        t = _mod2pi(theta + 0.5 * u + _PI)
        v = _mod2pi(phi - t + u)
        if t >= -_ZERO and u <= _ZERO:
            return True, t, u, v
    return False, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _lrlr_a(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    xi, eta = x + math.sin(phi), y - 1.0 - math.cos(phi)
    rho = 0.25 * (2.0 + math.sqrt(xi * xi + eta * eta))
    if rho <= 1.0:
        u = math.acos(rho)
        t, v = _tau_omega(u, -u, xi, eta, phi)
        if t >= -_ZERO and v <= _ZERO:
            return True, t, u, v
    return False, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _lrlr_b(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    xi, eta = x + math.sin(phi), y - 1.0 - math.cos(phi)
    rho = (20.0 - xi * xi - eta * eta) / 16.0
    if 0.0 <= rho <= 1.0:
        u = -math.acos(rho)
        if u >= -_HALF_PI:
            t, v = _tau_omega(u, u, xi, eta, phi)
            if t >= -_ZERO and v >= -_ZERO:
                return True, t, u, v
    return False, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _lrsl(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    rho, theta = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    if rho >= 2.0:
        r = math.sqrt(rho * rho - 4.0)
        u = 2.0 - r
        t = _mod2pi(theta + math.atan2(r, -2.0))
        v = _mod2pi(phi - _HALF_PI - t)
        if t >= -_ZERO and u <= _ZERO and v <= _ZERO:
            return True, t, u, v
    return False, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _lrsr(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    xi, eta = x + math.sin(phi), y - 1.0 - math.cos(phi)
    rho, theta = _polar(-eta, xi)
    if rho >= 2.0:
        t = theta
        u = 2.0 - rho
        v = _mod2pi(t + _HALF_PI - phi)
        if t >= -_ZERO and u <= _ZERO and v <= _ZERO:
            return True, t, u, v
    return False, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _lrslr(x: float, y: float, phi: float) -> tuple[bool, float, float, float]:
    xi, eta = x + math.sin(phi), y - 1.0 - math.cos(phi)
    rho, _ = _polar(xi, eta)
    if rho >= 2.0:
        u = 4.0 - math.sqrt(rho * rho - 4.0)
        if u <= _ZERO:
            t = _mod2pi(math.atan2((4.0 - u) * xi - 2.0 * eta, -2.0 * xi + (u - 4.0) * eta))
            v = _mod2pi(t - phi)
            if t >= -_ZERO and v >= -_ZERO:
                return True, t, u, v
    return False, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _keep(best: np.ndarray, kind: int, a: float, b: float, c: float, d: float, e: float) -> None:
    """Keep the path ``kind`` with segment lengths ``a..e`` in ``best`` (``[length, kind,
    a..e]``) when it is shorter."""
    total = abs(a) + abs(b) + abs(c) + abs(d) + abs(e)
    if total < best[0]:
        best[0] = total
        best[1] = kind
        best[2], best[3], best[4], best[5], best[6] = a, b, c, d, e


@njit(cache=True, nogil=True)
def _reeds_shepp(x: float, y: float, phi: float) -> np.ndarray:
    """The shortest Reeds-Shepp path to ``(x, y, phi)`` from the origin facing x, unit radius:
    ``[length, type, five signed segment lengths]``."""
    best = np.full(7, np.inf)
    best[2:] = 0.0
    xb = x * math.cos(phi) + y * math.sin(phi)
    yb = x * math.sin(phi) - y * math.cos(phi)
    hp = _HALF_PI
    for flip in range(4):  # as is, time-flipped, reflected, both
        sx = -1.0 if flip in (1, 3) else 1.0
        sy = -1.0 if flip in (2, 3) else 1.0
        sp = sx * sy
        sg = sx  # a time-flipped path runs every segment the other way
        rf = 1 if flip >= 2 else 0  # a reflected path swaps left and right: the next type
        ok, t, u, v = _lsl(sx * x, sy * y, sp * phi)
        if ok:
            _keep(best, 14 + rf, sg * t, sg * u, sg * v, 0.0, 0.0)
        ok, t, u, v = _lsr(sx * x, sy * y, sp * phi)
        if ok:
            _keep(best, 12 + rf, sg * t, sg * u, sg * v, 0.0, 0.0)
        ok, t, u, v = _lrl(sx * x, sy * y, sp * phi)
        if ok:
            _keep(best, 0 + rf, sg * t, sg * u, sg * v, 0.0, 0.0)
        ok, t, u, v = _lrl(sx * xb, sy * yb, sp * phi)
        if ok:
            _keep(best, 0 + rf, sg * v, sg * u, sg * t, 0.0, 0.0)
        ok, t, u, v = _lrlr_a(sx * x, sy * y, sp * phi)
        if ok:
            _keep(best, 2 + rf, sg * t, sg * u, -sg * u, sg * v, 0.0)
        ok, t, u, v = _lrlr_b(sx * x, sy * y, sp * phi)
        if ok:
            _keep(best, 2 + rf, sg * t, sg * u, sg * u, sg * v, 0.0)
        ok, t, u, v = _lrsl(sx * x, sy * y, sp * phi)
        if ok:
            _keep(best, 4 + rf, sg * t, -sg * hp, sg * u, sg * v, 0.0)
        ok, t, u, v = _lrsr(sx * x, sy * y, sp * phi)
        if ok:
            _keep(best, 8 + rf, sg * t, -sg * hp, sg * u, sg * v, 0.0)
        ok, t, u, v = _lrsl(sx * xb, sy * yb, sp * phi)
        if ok:
            _keep(best, 6 + rf, sg * v, sg * u, -sg * hp, sg * t, 0.0)
        ok, t, u, v = _lrsr(sx * xb, sy * yb, sp * phi)
        if ok:
            _keep(best, 10 + rf, sg * v, sg * u, -sg * hp, sg * t, 0.0)
        ok, t, u, v = _lrslr(sx * x, sy * y, sp * phi)
        if ok:
            _keep(best, 16 + rf, sg * t, -sg * hp, sg * u, -sg * hp, sg * v)
    return best


@njit(cache=True, nogil=True)
def _dubins(x: float, y: float, phi: float) -> np.ndarray:
    """The shortest Dubins path to ``(x, y, phi)`` from the origin facing x, unit radius:
    ``[length, type, three segment lengths, 0, 0]``."""
    best = np.full(7, np.inf)
    best[2:] = 0.0
    d = math.hypot(x, y)
    theta = math.atan2(y, x) % (2.0 * _PI)
    a = (-theta) % (2.0 * _PI)
    b = (phi - theta) % (2.0 * _PI)
    sa, sb, ca, cb = math.sin(a), math.sin(b), math.cos(a), math.cos(b)
    cab = math.cos(a - b)
    tp = 2.0 * _PI
    p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * (sa - sb)  # LSL
    if p2 >= 0:
        t1 = math.atan2(cb - ca, d + sa - sb)
        _keep(best, 0, (t1 - a) % tp, math.sqrt(p2), (b - t1) % tp, 0.0, 0.0)
    p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * (sb - sa)  # RSR
    if p2 >= 0:
        t1 = math.atan2(ca - cb, d - sa + sb)
        _keep(best, 1, (a - t1) % tp, math.sqrt(p2), (t1 - b) % tp, 0.0, 0.0)
    p2 = -2.0 + d * d + 2.0 * cab + 2.0 * d * (sa + sb)  # LSR
    if p2 >= 0:
        p = math.sqrt(p2)
        t2 = math.atan2(-ca - cb, d + sa + sb) - math.atan2(-2.0, p)
        _keep(best, 2, (t2 - a) % tp, p, (t2 - b) % tp, 0.0, 0.0)
    p2 = d * d - 2.0 + 2.0 * cab - 2.0 * d * (sa + sb)  # RSL
    if p2 >= 0:
        p = math.sqrt(p2)
        t2 = math.atan2(ca + cb, d - sa - sb) - math.atan2(2.0, p)
        _keep(best, 3, (a - t2) % tp, p, (b - t2) % tp, 0.0, 0.0)
    c = (6.0 - d * d + 2.0 * cab + 2.0 * d * (sa - sb)) / 8.0  # RLR
    if abs(c) <= 1.0:
        p = (tp - math.acos(c)) % tp
        t = (a - math.atan2(ca - cb, d - sa + sb) + p / 2.0) % tp
        _keep(best, 4, t, p, (a - b - t + p) % tp, 0.0, 0.0)
    c = (6.0 - d * d + 2.0 * cab + 2.0 * d * (sb - sa)) / 8.0  # LRL
    if abs(c) <= 1.0:
        p = (tp - math.acos(c)) % tp
        t = (-a - math.atan2(ca - cb, d + sa - sb) + p / 2.0) % tp
        _keep(best, 5, t, p, (b - a - t + p) % tp, 0.0, 0.0)
    return best


@njit(cache=True, nogil=True)
def shortest_curve(
    x0: float, y0: float, t0: float, x1: float, y1: float, t1: float, radius: float, reverse: bool
) -> np.ndarray:
    """The shortest path between two poses for ``radius``: ``[length (same unit as the
    poses), type, five signed lengths in radii]`` (Reeds-Shepp when ``reverse``, else
    Dubins)."""
    dx, dy = (x1 - x0) / radius, (y1 - y0) / radius
    c, s = math.cos(t0), math.sin(t0)
    x, y, phi = c * dx + s * dy, -s * dx + c * dy, _mod2pi(t1 - t0)
    best = _reeds_shepp(x, y, phi) if reverse else _dubins(x, y, phi)
    best[0] *= radius
    return best


@njit(cache=True, nogil=True)
def curve_codes(kind: int, reverse: bool) -> np.ndarray:
    return _RS_TYPES[kind] if reverse else np.append(_DUBINS_TYPES[kind], np.array([3, 3]))


@njit(cache=True, nogil=True)
def sample_segments(
    x: float, y: float, theta: float, codes: np.ndarray, lengths: np.ndarray, radius: float,
    step: float,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Poses every ``step`` at most (same unit as ``radius``) along a path from ``(x, y,
    theta)``, its ends included, and the direction (1, -1) of the motion that reaches each (the
    first: the first segment's)."""
    count = 1
    for i in range(5):
        if codes[i] != NONE and lengths[i] != 0.0:
            count += max(1, math.ceil(abs(lengths[i]) * radius / step))
    out = np.empty((count, 3))
    direction = np.ones(count, dtype=np.int8)
    out[0, 0], out[0, 1], out[0, 2] = x, y, theta
    k = 1
    for i in range(5):
        code, length = codes[i], lengths[i]
        if code == NONE or length == 0.0:
            continue
        n = max(1, math.ceil(abs(length) * radius / step))
        sign = 1 if length > 0 else -1
        if k == 1:
            direction[0] = sign
        for j in range(1, n + 1):
            a = length * j / n
            if code == STRAIGHT:
                out[k, 0] = x + a * radius * math.cos(theta)
                out[k, 1] = y + a * radius * math.sin(theta)
                out[k, 2] = theta
            elif code == LEFT:
                out[k, 0] = x + radius * (math.sin(theta + a) - math.sin(theta))
                out[k, 1] = y - radius * (math.cos(theta + a) - math.cos(theta))
                out[k, 2] = theta + a
            else:
                out[k, 0] = x - radius * (math.sin(theta - a) - math.sin(theta))
                out[k, 1] = y + radius * (math.cos(theta - a) - math.cos(theta))
                out[k, 2] = theta - a
            direction[k] = sign
            k += 1
        x, y, theta = out[k - 1, 0], out[k - 1, 1], out[k - 1, 2]
    return out, direction


@dataclass(frozen=True, slots=True)
class Curve:
    """A shortest path between two poses: its ``length``, segment ``codes`` and signed
    ``lengths`` (in radii), ``radius``, and whether it may reverse."""

    start: tuple[float, float, float]
    length: float
    codes: tuple[int, ...]
    lengths: tuple[float, ...]
    radius: float
    reverse: bool

    @property
    def cusps(self) -> int:
        """Changes of direction along the path."""
        signs = [1 if v > 0 else -1 for v in self.lengths if v != 0.0]
        return sum(1 for a, b in itertools.pairwise(signs) if a != b)

    def sample(self, step: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]]:
        """Poses ``[x, y, yaw]`` at most ``step`` apart from start to end, and the direction of
        the motion reaching each."""
        return sample_curve(self, step)


def _pose(value: Any, name: str) -> tuple[float, float, float]:
    p = tuple(float(v) for v in value)
    if len(p) != 3 or not all(math.isfinite(v) for v in p):
        raise InvalidInput(f"{name} must be a finite pose (x, y, yaw); got {value!r}", field=name)
    return p[0], p[1], p[2]


def _make_curve(start: Any, goal: Any, radius: float, reverse: bool) -> Curve:
    s, g = _pose(start, "start"), _pose(goal, "goal")
    if not (math.isfinite(radius) and radius > 0):
        msg = f"min_turning_radius must be a number of meters > 0; got {radius!r}"
        raise InvalidInput(msg, field="min_turning_radius")
    best = shortest_curve(*s, *g, float(radius), reverse)
    codes = curve_codes(int(best[1]), reverse)
    return Curve(s, float(best[0]), tuple(int(c) for c in codes),
                 tuple(float(v) for v in best[2:]), float(radius), reverse)  # fmt: skip


def reeds_shepp(start: Any, goal: Any, radius: float) -> Curve:
    """The shortest Reeds-Shepp path (forward and reverse) from pose ``start`` to ``goal``
    (``(x, y, yaw)``) for a turning ``radius``."""
    return _make_curve(start, goal, radius, True)


def dubins(start: Any, goal: Any, radius: float) -> Curve:
    """The shortest Dubins path (forward only) from pose ``start`` to ``goal``."""
    return _make_curve(start, goal, radius, False)


def sample_curve(curve: Curve, step: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]]:
    """:meth:`Curve.sample`."""
    if not step > 0:
        raise InvalidInput(f"step must be > 0; got {step!r}", field="step")
    codes = np.array(curve.codes, dtype=np.int64)
    lengths = np.array(curve.lengths, dtype=np.float64)
    poses, direction = sample_segments(*curve.start, codes, lengths, curve.radius, float(step))
    return poses, direction

"""Speed along the poses (docs/zones.md): the cap speed zones put on each pose, and the time to
drive the poses at a nominal speed within those caps.

>>> import numpy as np
>>> poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
>>> drive_time(poses, np.array([np.inf, np.inf, 0.25]), nominal_speed=0.5)
10.0
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.maps.zones import Zones, speed_limits
from planner.params import Params

__all__ = ["drive_time", "duration", "pose_speeds", "profile_time"]


def pose_speeds(zones: Zones | None, poses: Any) -> npt.NDArray[np.float64]:
    """The speed cap (m/s) at each pose ``[x, y, yaw]``: the least ``max_speed`` of the speed
    zones holding its point, ``inf`` outside every zone."""
    xy = np.asarray(poses, dtype=np.float64).reshape(-1, 3)[:, :2]
    if zones is None or not zones.speed:
        return np.full(len(xy), np.inf)
    return speed_limits(zones, xy)


def drive_time(
    poses: npt.NDArray[np.float64], caps: npt.NDArray[np.float64], *, nominal_speed: float
) -> float:
    """Seconds to drive the poses' polyline at ``nominal_speed`` m/s, each segment at most the
    cap of either of its ends (a robot slows down before it enters a speed zone and speeds up
    only once it has left it)."""
    if len(poses) < 2:
        return 0.0
    steps = np.diff(poses[:, :2], axis=0)
    lengths = np.hypot(steps[:, 0], steps[:, 1])
    speed = np.minimum(nominal_speed, np.minimum(caps[:-1], caps[1:]))
    return float(np.sum(lengths / speed))


def profile_time(
    poses: npt.NDArray[np.float64],
    direction: npt.NDArray[np.int8],
    caps: npt.NDArray[np.float64],
    *,
    max_velocity: float,
    max_acceleration: float = math.inf,
    max_angular_velocity: float = math.inf,
) -> float:
    """Seconds to drive ``poses`` on a trapezoid speed profile: at most ``max_velocity`` m/s
    and each pose's cap, slower on a curve (at most ``max_angular_velocity / curvature``),
    speeding up and slowing down at ``max_acceleration`` m/s², stopped at the ends, at each
    change of ``direction`` (1 forward, -1 reverse) and for each turn in place (two poses at
    one point), which takes its angle over ``max_angular_velocity``.

    >>> line = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    >>> profile_time(line, np.ones(2, np.int8), np.full(2, np.inf), max_velocity=1.0,
    ...              max_acceleration=0.5)   # 2 s up, 6 m at 1 m/s, 2 s down
    12.0
    """
    if len(poses) < 2:
        return 0.0
    step = np.diff(poses[:, :2], axis=0)
    ds = np.hypot(step[:, 0], step[:, 1])
    turn = np.abs(np.angle(np.exp(1j * np.diff(poses[:, 2]))))
    in_place = ds < 1e-9
    with np.errstate(divide="ignore", invalid="ignore"):
        curve_cap = np.where(turn > 1e-12, max_angular_velocity * ds / turn, np.inf)
    seg_cap = np.minimum(np.minimum(max_velocity, curve_cap), np.minimum(caps[:-1], caps[1:]))
    seg_cap[in_place] = 0.0
    v = np.full(len(poses), np.inf)
    v[1:-1] = np.minimum(seg_cap[:-1], seg_cap[1:])
    v[0] = v[-1] = 0.0
    cusp = np.zeros(len(poses), dtype=bool)
    cusp[1:-1] = direction[1:-1] != direction[2:]
    v[cusp] = 0.0
    a = max_acceleration
    for i in range(len(ds)):  # forward: no faster than speeding up from the last pose allows
        v[i + 1] = min(v[i + 1], math.sqrt(v[i] ** 2 + 2 * a * ds[i]) if a < math.inf else v[i + 1])
    for i in range(len(ds) - 1, -1, -1):  # backward: no faster than slowing down allows
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2 * a * ds[i]) if a < math.inf else v[i])
    total = float(np.sum(turn[in_place]) / max_angular_velocity) if in_place.any() else 0.0
    for k in np.flatnonzero(~in_place).tolist():
        total += _segment_time(float(ds[k]), float(v[k]), float(v[k + 1]), float(seg_cap[k]), a)
    return total


def _segment_time(ds: float, v0: float, v1: float, top: float, a: float) -> float:
    """Seconds over ``ds`` meters from ``v0`` to ``v1`` m/s, at most ``top``, accelerating at
    ``a``: up to the highest speed the length allows, cruise, down."""
    if a == math.inf:
        return ds / top
    peak = min(top, math.sqrt((2 * a * ds + v0 * v0 + v1 * v1) / 2))
    up = (peak * peak - v0 * v0) / (2 * a)
    down = (peak * peak - v1 * v1) / (2 * a)
    cruise = max(0.0, ds - up - down)
    return (peak - v0) / a + (peak - v1) / a + cruise / peak


def duration(
    poses: npt.NDArray[np.float64],
    direction: npt.NDArray[np.int8],
    caps: npt.NDArray[np.float64],
    params: Params,
) -> float:
    """A plan's ``duration_s``: its poses at ``nominal_speed`` within the speed caps
    (:func:`drive_time`), or with ``max_velocity`` on the trapezoid profile of
    :func:`profile_time`."""
    p = params
    if p.max_velocity is None:
        return drive_time(poses, caps, nominal_speed=p.nominal_speed)
    return profile_time(
        poses, direction, caps, max_velocity=p.max_velocity,
        max_acceleration=p.max_acceleration or math.inf,
        max_angular_velocity=p.max_angular_velocity or math.inf,
    )  # fmt: skip

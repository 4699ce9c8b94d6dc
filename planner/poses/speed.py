"""Speed along the poses (docs/zones.md): the cap speed zones put on each pose, and the time to
drive the poses at a nominal speed within those caps.

>>> import numpy as np
>>> poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
>>> drive_time(poses, np.array([np.inf, np.inf, 0.25]), nominal_speed=0.5)
10.0
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from planner.maps.zones import Zones, speed_limits

__all__ = ["drive_time", "pose_speeds"]


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

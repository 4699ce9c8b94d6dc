"""Poses as a ROS ``nav_msgs/Path``, in rosbridge's JSON."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from planner.errors import InvalidInput, quote

__all__ = ["FRAME_ID", "nav_msgs_path"]

FRAME_ID = re.compile(r"/?[A-Za-z0-9_][A-Za-z0-9_./-]*")
"""A frame name: letters, digits, ``_ . / -`` (a leading ``/`` allowed), 128 characters at most."""


def nav_msgs_path(poses: Any, frame_id: str = "map", stamp: float = 0.0) -> dict[str, Any]:
    """``(m, 3)`` poses ``[x, y, yaw]`` as a ``nav_msgs/Path`` the way rosbridge writes it: a
    ``header`` (``frame_id``, ``stamp`` ``{sec, nanosec}`` from ``stamp`` seconds) and, for each
    pose, a ``geometry_msgs/PoseStamped`` at ``(x, y, 0)`` oriented by the yaw's quaternion
    ``(0, 0, sin(yaw/2), cos(yaw/2))``.

    >>> path = nav_msgs_path([[1.0, 2.0, math.pi / 2]], "odom", 12.5)
    >>> path["header"]
    {'frame_id': 'odom', 'stamp': {'sec': 12, 'nanosec': 500000000}}
    >>> q = path["poses"][0]["pose"]["orientation"]
    >>> round(q["z"], 6), round(q["w"], 6)
    (0.707107, 0.707107)
    """
    if not isinstance(frame_id, str) or len(frame_id) > 128 or not FRAME_ID.fullmatch(frame_id):
        msg = (
            "frame_id must be 1-128 letters, digits, '_', '.', '/' or '-' (starting with a "
            f"letter, digit, '_' or '/'); got {quote(frame_id)}"
        )
        raise InvalidInput(msg, field="frame_id")
    P = np.asarray(poses, dtype=np.float64)
    if P.ndim != 2 or P.shape[1:] != (3,) or not np.isfinite(P).all():
        raise InvalidInput(
            f"poses must be an (m, 3) array of finite numbers; got {P.shape}", field="poses"
        )
    if not (math.isfinite(stamp) and stamp >= 0):
        raise InvalidInput(f"stamp must be seconds >= 0; got {quote(stamp)}", field="stamp")
    sec = int(stamp)
    nanosec = min(round((stamp - sec) * 1e9), 999_999_999)
    header = {"frame_id": frame_id, "stamp": {"sec": sec, "nanosec": nanosec}}
    return {
        "header": header,
        "poses": [
            {
                "header": header,
                "pose": {
                    "position": {"x": x, "y": y, "z": 0.0},
                    "orientation": {
                        "x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)
                    },
                },
            }
            for x, y, yaw in P.tolist()
        ],
    }  # fmt: skip

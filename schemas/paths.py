"""``GET /plan/{plan_id}/path``: a plan's poses as a rosbridge-style ``nav_msgs/Path``."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "FRAME_ID_MAX",
    "FRAME_ID_PATTERN",
    "NavHeader",
    "NavPath",
    "NavPose",
    "NavPoseStamped",
    "NavQuaternion",
    "NavStamp",
    "NavVector",
]

FRAME_ID_PATTERN = r"^/?[A-Za-z0-9_][A-Za-z0-9_./-]*$"
"""A ROS frame name: letters, digits, ``_ . / -`` (a leading ``/`` allowed, as tf once wrote)."""
FRAME_ID_MAX = 128

_HEADER: dict[str, Any] = {"frame_id": "map", "stamp": {"sec": 1764084000, "nanosec": 0}}
_POSE: dict[str, Any] = {
    "position": {"x": 0.5, "y": 4.5, "z": 0.0},
    "orientation": {"x": 0.0, "y": 0.0, "z": -0.122, "w": 0.9925},
}
EXAMPLE_PATH: dict[str, Any] = {
    "header": _HEADER,
    "poses": [{"header": _HEADER, "pose": _POSE}],
}


class NavStamp(BaseModel):
    """``builtin_interfaces/Time``: when the path was made."""

    model_config = ConfigDict(json_schema_extra={"examples": [_HEADER["stamp"]]})

    sec: int = Field(ge=0)
    nanosec: int = Field(ge=0, lt=10**9)


class NavHeader(BaseModel):
    """``std_msgs/Header``."""

    model_config = ConfigDict(json_schema_extra={"examples": [_HEADER]})

    frame_id: str
    stamp: NavStamp


class NavVector(BaseModel):
    """``geometry_msgs/Point``: meters (``z`` is 0)."""

    model_config = ConfigDict(json_schema_extra={"examples": [_POSE["position"]]})

    x: float
    y: float
    z: float = 0.0


class NavQuaternion(BaseModel):
    """``geometry_msgs/Quaternion`` of a yaw: ``(0, 0, sin(yaw/2), cos(yaw/2))``."""

    model_config = ConfigDict(json_schema_extra={"examples": [_POSE["orientation"]]})

    x: float = 0.0
    y: float = 0.0
    z: float
    w: float


class NavPose(BaseModel):
    """``geometry_msgs/Pose``."""

    model_config = ConfigDict(json_schema_extra={"examples": [_POSE]})

    position: NavVector
    orientation: NavQuaternion


class NavPoseStamped(BaseModel):
    """``geometry_msgs/PoseStamped``."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_PATH["poses"][0]]})

    header: NavHeader
    pose: NavPose


class NavPath(BaseModel):
    """``nav_msgs/Path`` as rosbridge writes it: the plan's poses, in the frame asked for."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_PATH]})

    header: NavHeader
    poses: list[NavPoseStamped]

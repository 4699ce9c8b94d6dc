"""Robot maps in meters: an occupancy grid with a frame, from a grid or a
``nav_msgs/OccupancyGrid``, and the map's content hash.

>>> m = grid_map([[0, 1], [-1, 0]], resolution=0.5, origin=(1.0, 2.0, 0.0))
>>> m.occupancy.tolist(), m.unknown_cells
([[0, 100], [-1, 0]], 1)
>>> m.frame.centers([[0, 0], [1, 1]]).tolist()
[[1.25, 2.75], [1.75, 2.25]]
>>> m.frame.cell_of((1.9, 2.9))
(0, 1)
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.errors import InvalidInput, quote
from planner.maps.frames import MapFrame, framed, origin_of, resolution_of
from planner.maps.grids import grid_array
from planner.maps.zones import Zones
from planner.parsing import number

__all__ = ["MapFrame", "RobotMap", "grid_map", "occupancy_grid_map"]

Occupancy = npt.NDArray[np.int8]


@dataclass(frozen=True, eq=False)
class RobotMap:
    """An occupancy map with a frame: ``occupancy`` (``int8`` H x W, ``-1`` unknown, ``0..100``;
    row 0 at the top) and ``frame`` (resolution, origin); a zoned map (docs/zones.md) also its
    ``zones``, its keepout already blocked in ``occupancy``. Read-only.
    """

    occupancy: Occupancy
    frame: MapFrame
    zones: Zones | None = None

    def __post_init__(self) -> None:
        self.occupancy.flags.writeable = False

    @property
    def shape(self) -> tuple[int, int]:
        return self.frame.shape

    @property
    def resolution(self) -> float:
        return self.frame.resolution

    @property
    def origin(self) -> tuple[float, float, float]:
        return self.frame.origin

    def blocked(self, occupied_threshold: int = 65) -> npt.NDArray[np.bool_]:
        """Cells whose occupancy is at least ``occupied_threshold`` percent."""
        out: npt.NDArray[np.bool_] = self.occupancy >= occupied_threshold
        return out

    @cached_property
    def unknown_cells(self) -> int:
        return int(np.count_nonzero(self.occupancy < 0))

    def occupied_cells(self, occupied_threshold: int = 65) -> int:
        return int(np.count_nonzero(self.blocked(occupied_threshold)))

    def free_cells(self, occupied_threshold: int = 65) -> int:
        occ = self.occupancy
        return int(np.count_nonzero((occ >= 0) & (occ < occupied_threshold)))

    @cached_property
    def plain(self) -> bool:
        """A plain 0/1 grid: the default frame, every cell 0 or 100. Such a map keeps the id and
        the analysis it had before maps had frames."""
        occ = self.occupancy
        return self.frame.is_default and bool(np.all((occ == 0) | (occ == 100)))

    @cached_property
    def map_id(self) -> str:
        """Hex SHA-256 of shape, occupancy, resolution and origin: the same map gets the same id
        whether it came as YAML + image, OccupancyGrid or grid. A plain 0/1 grid keeps its
        historical id, the hash of ``"{H}x{W}:"`` and its 0/1 bytes. A zoned map's also hashes
        its zones (and so its base map's id)."""
        H, W = self.shape
        if self.plain and self.zones is None:
            cells = (self.occupancy == 100).astype(np.uint8)
            return hashlib.sha256(f"{H}x{W}:".encode() + cells.tobytes()).hexdigest()
        res, (ox, oy, yaw) = self.resolution, self.origin
        # Rounded, so that a yaw gone through a quaternion (OccupancyGrid) hashes as the YAML's.
        frame = f"|res {res:.9g}|origin {_canon(ox, 6)} {_canon(oy, 6)} {_canon(yaw, 9)}"
        data = f"occupancy {H}x{W}:".encode() + self.occupancy.tobytes() + frame.encode()
        if self.zones is not None:
            zones = json.dumps(self.zones.as_dict(), sort_keys=True, separators=(",", ":"))
            data += b"|zones " + zones.encode()
        return hashlib.sha256(data).hexdigest()

    def to_occupancy_grid(self) -> dict[str, Any]:
        """The map as rosbridge writes a ``nav_msgs/OccupancyGrid`` (row 0 at the bottom)."""
        H, W = self.shape
        ox, oy, yaw = self.origin
        return {
            "header": {"frame_id": "map"},
            "info": {
                "resolution": self.resolution,
                "width": W,
                "height": H,
                "origin": {
                    "position": {"x": ox, "y": oy, "z": 0.0},
                    "orientation": {
                        "x": 0.0,
                        "y": 0.0,
                        "z": math.sin(yaw / 2),
                        "w": math.cos(yaw / 2),
                    },
                },
            },
            "data": self.occupancy[::-1].ravel().tolist(),
        }


def _canon(value: float, digits: int) -> str:
    text = f"{value:.{digits}f}"
    return "0" if float(text) == 0 else text  # no "-0.000000"


def grid_map(
    grid: Any, *, resolution: Any = 1.0, origin: Any = (0.0, 0.0, 0.0), name: str = "grid"
) -> RobotMap:
    """A map from a grid of ``0`` (free), ``1`` (blocked) and ``-1`` (unknown), with a frame."""
    arr = grid_array(grid, name=name)
    bad = (arr != 0) & (arr != 1) & (arr != -1)
    if bad.any():
        r, c = (int(v) for v in np.argwhere(bad)[0])
        msg = (
            f"{name} must hold only 0 (free), 1 (blocked) and -1 (unknown); "
            f"found {quote(arr[r, c].item())} at [{r}, {c}]"
        )
        raise InvalidInput(msg, field=name)
    occupancy = np.where(arr == 1, 100, arr).astype(np.int8)
    frame = framed(
        (int(arr.shape[0]), int(arr.shape[1])),
        resolution_of(resolution, "resolution"),
        origin_of(origin, "origin"),
    )
    return RobotMap(np.ascontiguousarray(occupancy), frame)


def occupancy_grid_map(message: Any, *, name: str = "occupancy_grid") -> RobotMap:
    """A map from a ``nav_msgs/OccupancyGrid`` as rosbridge writes it (a dict): ``info``
    (``resolution``, ``width``, ``height``, ``origin`` pose) and ``data``, row-major with row 0
    at the origin (the bottom of the image), ``-1`` or ``0..100``."""
    if not isinstance(message, Mapping):
        raise InvalidInput(f"{name} must be an object; got {quote(message)}", field=name)
    info = _key(message, "info", name)
    if not isinstance(info, Mapping):
        raise InvalidInput(
            f"{name}.info must be an object; got {quote(info)}", field=f"{name}.info"
        )
    width = _size(_key(info, "width", f"{name}.info"), f"{name}.info.width")
    height = _size(_key(info, "height", f"{name}.info"), f"{name}.info.height")
    resolution = resolution_of(_key(info, "resolution", f"{name}.info"), f"{name}.info.resolution")
    pose = _key(info, "origin", f"{name}.info")
    origin = _pose(pose, f"{name}.info.origin")
    fields = (f"{name}.info.resolution", f"{name}.info.origin")
    frame = framed((height, width), resolution, origin, fields=fields)
    data = _key(message, "data", name)
    field = f"{name}.data"
    try:
        values = np.asarray(data)
    except ValueError:
        values = np.asarray([None])
    if (
        values.dtype == object
        or values.ndim != 1
        or not (np.issubdtype(values.dtype, np.integer) or values.size == 0)
    ):
        msg = f"{field} must be a flat list of integers -1..100; got {quote(data)}"
        raise InvalidInput(msg, field=field)
    if values.size != width * height:
        msg = (
            f"{field} has {values.size} values; width x height is {width} x {height} = "
            f"{width * height}"
        )
        raise InvalidInput(msg, field=field)
    bad = np.flatnonzero((values < -1) | (values > 100))
    if bad.size:
        i = int(bad[0])
        msg = f"{field} must hold -1 (unknown) or 0..100; found {values[i].item()} at index {i}"
        raise InvalidInput(msg, field=field)
    occupancy = values.astype(np.int8).reshape(height, width)[::-1]
    return RobotMap(np.ascontiguousarray(occupancy), frame)


def _key(mapping: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in mapping:
        raise InvalidInput(f"{where} has no '{key}'", field=f"{where}.{key}")
    return mapping[key]


def _size(value: Any, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value <= 0:
        raise InvalidInput(f"{field} must be a positive integer; got {quote(value)}", field=field)
    return int(value)


def _pose(pose: Any, field: str) -> tuple[float, float, float]:
    if not isinstance(pose, Mapping):
        raise InvalidInput(f"{field} must be a pose object; got {quote(pose)}", field=field)
    position = _key(pose, "position", field)
    orientation = pose.get("orientation", {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0})
    for part, value in (("position", position), ("orientation", orientation)):
        if not isinstance(value, Mapping):
            msg = f"{field}.{part} must be an object; got {quote(value)}"
            raise InvalidInput(msg, field=f"{field}.{part}")
        # A part left out is a ROS message's default (0, the identity rotation); a key that is
        # no part (a mistyped "X") is refused rather than read as that default.
        names = ("x", "y", "z", "w") if part == "orientation" else ("x", "y", "z")
        unknown = sorted(str(k) for k in value if k not in names)
        if unknown:
            msg = f"{field}.{part} has no field {quote(unknown[0])} (it takes {', '.join(names)})"
            raise InvalidInput(msg, field=f"{field}.{part}.{unknown[0][:100]}")
    x = number(position.get("x", 0.0), f"{field}.position.x")
    y = number(position.get("y", 0.0), f"{field}.position.y")
    qx, qy, qz, qw = (
        number(orientation.get(k, 1.0 if k == "w" else 0.0), f"{field}.orientation.{k}")
        for k in "xyzw"
    )
    if qx * qx + qy * qy + qz * qz + qw * qw == 0:
        msg = f"{field}.orientation is not a rotation; got {quote(dict(orientation))}"
        raise InvalidInput(msg, field=f"{field}.orientation")
    yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    return (x + 0.0, y + 0.0, yaw + 0.0)

"""Robot maps in meters: ROS ``map_server`` YAML + image, ``nav_msgs/OccupancyGrid``, and grids
with a frame; the map frame (cell centers in meters, and back) and the map's content hash.

Pixels become occupancy exactly as Nav2's ``map_server`` (``map_io.cpp``, ``loadMapFromFile``)
does, vectorised. Occupancy is ``-1`` (unknown) or ``0..100``; row 0 is the top of the image.

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
import io
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import yaml
from PIL import Image, UnidentifiedImageError

from planner._errors import InvalidInput, quote
from planner.maps.grids import grid_array

__all__ = [
    "DEFAULT_FREE_THRESH",
    "DEFAULT_OCCUPIED_THRESH",
    "MapFrame",
    "MapMode",
    "MapYaml",
    "RobotMap",
    "decode_map_image",
    "grid_map",
    "image_size",
    "occupancy_grid_map",
    "parse_map_yaml",
    "parse_ros_map",
    "read_ros_map",
]

MapMode = Literal["trinary", "scale", "raw"]

#: map_server's customary thresholds, used when a YAML leaves them out.
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196

Occupancy = npt.NDArray[np.int8]
Cells = npt.NDArray[np.int64]
Points = npt.NDArray[np.float64]

# --------------------------------------------------------------------------------------------
# The frame


@dataclass(frozen=True, slots=True)
class MapFrame:
    """Where a map's cells are in meters: its shape, ``resolution`` (m/cell) and ``origin``
    ``(x, y, yaw)``, the pose of the lower-left corner of the bottom-left cell (ROS's origin).

    Cell ``[row, col]`` (row 0 at the top) has its center at ``x = ox + (col + 0.5) res``,
    ``y = oy + (H - 1 - row + 0.5) res``, rotated by ``yaw`` about ``(ox, oy)``.
    """

    shape: tuple[int, int]
    resolution: float = 1.0
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def is_default(self) -> bool:
        """1 m a cell, origin ``[0, 0, 0]``: a plain grid's frame."""
        return self.resolution == 1.0 and self.origin == (0.0, 0.0, 0.0)

    def centers(self, cells: Any) -> Points:
        """The centers, in meters, of an ``(n, 2)`` array of ``[row, col]`` cells: ``(n, 2)``
        ``[x, y]``."""
        rc = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
        ox, oy, yaw = self.origin
        u = (rc[:, 1] + 0.5) * self.resolution
        v = (self.shape[0] - 1 - rc[:, 0] + 0.5) * self.resolution
        cos, sin = math.cos(yaw), math.sin(yaw)
        out: Points = np.stack([ox + cos * u - sin * v, oy + sin * u + cos * v], axis=1)
        return out

    def cells(self, points: Any) -> Cells:
        """The cells containing an ``(n, 2)`` array of ``[x, y]`` points (no bounds check)."""
        xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        ox, oy, yaw = self.origin
        dx, dy = xy[:, 0] - ox, xy[:, 1] - oy
        cos, sin = math.cos(yaw), math.sin(yaw)
        u = (cos * dx + sin * dy) / self.resolution
        v = (-sin * dx + cos * dy) / self.resolution
        col = np.floor(u)
        row = self.shape[0] - 1 - np.floor(v)
        out: Cells = np.stack([row, col], axis=1).astype(np.int64)
        return out

    def cell_of(self, point: Any, *, name: str = "point") -> tuple[int, int]:
        """The cell containing one point, given as ``(x, y)`` or ``{"x": .., "y": ..}``.

        >>> MapFrame((2, 3), 0.5).cell_of({"x": 9.0, "y": 0.0}, name="goal")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        planner._errors.InvalidInput: goal {'x': 9.0, 'y': 0.0} is outside the map: ...
        """
        x, y = point_xy(point, name=name)
        (r, c), *_ = self.cells([[x, y]]).tolist()
        if not (0 <= r < self.shape[0] and 0 <= c < self.shape[1]):
            raise InvalidInput(
                f"{name} {quote(point)} is outside the map: {self.describe()}", field=name
            )
        return int(r), int(c)

    def describe(self) -> str:
        H, W = self.shape
        res, (ox, oy, yaw) = self.resolution, self.origin
        if yaw == 0:
            span = f"it spans x [{ox:g}, {ox + W * res:g}], y [{oy:g}, {oy + H * res:g}]"
        else:
            span = f"{W * res:g} m x {H * res:g} m, rotated by yaw {yaw:g}"
        return f"{span} (resolution {res:g} m, origin {list(self.origin)})"


def point_xy(point: Any, *, name: str) -> tuple[float, float]:
    """A point as ``(x, y)`` floats, from ``{"x", "y"}`` or a pair; finite, else InvalidInput."""
    if isinstance(point, Mapping):
        if "x" not in point or "y" not in point:
            raise InvalidInput(f"{name} must have 'x' and 'y'; got {quote(point)}", field=name)
        values: list[Any] = [point["x"], point["y"]]
    elif isinstance(point, Sequence | np.ndarray) and not isinstance(point, str | bytes):
        values = list(point)
    else:
        raise InvalidInput(
            f"{name} must be a point (x, y) in meters; got {quote(point)}", field=name
        )
    ok = len(values) == 2 and all(
        isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool)
        for v in values
    )
    if not ok or not all(math.isfinite(float(v)) for v in values):
        msg = f"{name} must be a point (x, y) of finite numbers in meters; got {quote(point)}"
        raise InvalidInput(msg, field=name)
    return float(values[0]), float(values[1])


# --------------------------------------------------------------------------------------------
# The map


@dataclass(frozen=True, eq=False)
class RobotMap:
    """An occupancy map with a frame: ``occupancy`` (``int8`` H x W, ``-1`` unknown, ``0..100``;
    row 0 at the top) and ``frame`` (resolution, origin). Read-only.
    """

    occupancy: Occupancy
    frame: MapFrame

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
        historical id, the hash of ``"{H}x{W}:"`` and its 0/1 bytes."""
        H, W = self.shape
        if self.plain:
            cells = (self.occupancy == 100).astype(np.uint8)
            return hashlib.sha256(f"{H}x{W}:".encode() + cells.tobytes()).hexdigest()
        res, (ox, oy, yaw) = self.resolution, self.origin
        # Rounded, so that a yaw gone through a quaternion (OccupancyGrid) hashes as the YAML's.
        frame = f"|res {res:.9g}|origin {_canon(ox, 6)} {_canon(oy, 6)} {_canon(yaw, 9)}"
        data = f"occupancy {H}x{W}:".encode() + self.occupancy.tobytes() + frame.encode()
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


# --------------------------------------------------------------------------------------------
# Grids and OccupancyGrid messages


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
    frame = MapFrame(
        (int(arr.shape[0]), int(arr.shape[1])),
        _resolution(resolution, "resolution"),
        _origin(origin, "origin"),
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
    resolution = _resolution(_key(info, "resolution", f"{name}.info"), f"{name}.info.resolution")
    pose = _key(info, "origin", f"{name}.info")
    origin = _pose(pose, f"{name}.info.origin")
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
    frame = MapFrame((height, width), resolution, origin)
    return RobotMap(np.ascontiguousarray(occupancy), frame)


def _key(mapping: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in mapping:
        raise InvalidInput(f"{where} has no '{key}'", field=f"{where}.{key}")
    return mapping[key]


def _number(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise InvalidInput(f"{field} must be a number; got {quote(value)}", field=field)
    if not math.isfinite(float(value)):
        raise InvalidInput(f"{field} must be finite; got {quote(value)}", field=field)
    return float(value)


def _size(value: Any, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value <= 0:
        raise InvalidInput(f"{field} must be a positive integer; got {quote(value)}", field=field)
    return int(value)


def _resolution(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise InvalidInput(
            f"{field} must be a number of meters per cell; got {quote(value)}", field=field
        )
    res = float(value)
    if not (math.isfinite(res) and res > 0):
        raise InvalidInput(f"{field} must be positive and finite; got {quote(value)}", field=field)
    return res


def _origin(value: Any, field: str) -> tuple[float, float, float]:
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence | np.ndarray):
        raise InvalidInput(f"{field} must be [x, y, yaw]; got {quote(value)}", field=field)
    items = list(value)
    if len(items) != 3:
        raise InvalidInput(f"{field} must be [x, y, yaw]; got {quote(value)}", field=field)
    x, y, yaw = (_number(v, field) for v in items)
    return (x + 0.0, y + 0.0, yaw + 0.0)  # + 0.0: no negative zero


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
    x = _number(position.get("x", 0.0), f"{field}.position.x")
    y = _number(position.get("y", 0.0), f"{field}.position.y")
    qx, qy, qz, qw = (
        _number(orientation.get(k, 1.0 if k == "w" else 0.0), f"{field}.orientation.{k}")
        for k in "xyzw"
    )
    if qx * qx + qy * qy + qz * qz + qw * qw == 0:
        msg = f"{field}.orientation is not a rotation; got {quote(dict(orientation))}"
        raise InvalidInput(msg, field=f"{field}.orientation")
    yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    return (x + 0.0, y + 0.0, yaw + 0.0)


# --------------------------------------------------------------------------------------------
# ROS map_server YAML + image


@dataclass(frozen=True, slots=True)
class MapYaml:
    """A ROS ``map_server`` map YAML, validated."""

    image: str
    resolution: float
    origin: tuple[float, float, float]
    negate: bool = False
    occupied_thresh: float = DEFAULT_OCCUPIED_THRESH
    free_thresh: float = DEFAULT_FREE_THRESH
    mode: MapMode = "trinary"


def parse_map_yaml(text: str | bytes, *, name: str = "yaml") -> MapYaml:
    """Read a map YAML (``yaml.safe_load``): ``image``, ``resolution``, ``origin`` required;
    ``negate`` (0), ``occupied_thresh`` (0.65), ``free_thresh`` (0.196), ``mode`` (trinary).

    >>> meta = parse_map_yaml("image: m.pgm\\nresolution: 0.05\\norigin: [-1, 2, 0]\\nmode: scale")
    >>> meta.origin, meta.negate, meta.occupied_thresh, meta.free_thresh, meta.mode
    ((-1.0, 2.0, 0.0), False, 0.65, 0.196, 'scale')
    >>> parse_map_yaml("resolution: 0.05\\norigin: [0, 0, 0]\\nmode: colour")
    Traceback (most recent call last):
    ...
    planner._errors.InvalidInput: yaml.mode must be trinary, scale or raw; got 'colour'
    """
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise InvalidInput(f"{name} is not valid YAML: {quote(str(exc))}", field=name) from None
    if not isinstance(doc, dict):
        raise InvalidInput(f"{name} must be a mapping of keys; got {quote(doc)}", field=name)
    image = doc.get("image", "")
    if not isinstance(image, str):
        raise InvalidInput(
            f"{name}.image must be a file name; got {quote(image)}", field=f"{name}.image"
        )
    for key in ("resolution", "origin"):
        if key not in doc:
            raise InvalidInput(f"{name} has no '{key}'", field=f"{name}.{key}")
    resolution = _resolution(doc["resolution"], f"{name}.resolution")
    origin = _origin(doc["origin"], f"{name}.origin")
    negate = doc.get("negate", 0)
    if negate not in (0, 1) or not isinstance(negate, int):  # bool is an int too
        msg = f"{name}.negate must be 0 or 1; got {quote(negate)}"
        raise InvalidInput(msg, field=f"{name}.negate")
    thresholds = {}
    for key, default in (
        ("occupied_thresh", DEFAULT_OCCUPIED_THRESH),
        ("free_thresh", DEFAULT_FREE_THRESH),
    ):
        value = _number(doc.get(key, default), f"{name}.{key}")
        if not 0.0 <= value <= 1.0:
            msg = f"{name}.{key} must be in [0, 1]; got {quote(doc[key])}"
            raise InvalidInput(msg, field=f"{name}.{key}")
        thresholds[key] = value
    if thresholds["free_thresh"] >= thresholds["occupied_thresh"]:
        msg = (
            f"{name}.free_thresh must be less than occupied_thresh; got free_thresh "
            f"{thresholds['free_thresh']!r} and occupied_thresh {thresholds['occupied_thresh']!r}"
        )
        raise InvalidInput(msg, field=f"{name}.free_thresh")
    mode = doc.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        msg = f"{name}.mode must be trinary, scale or raw; got {quote(mode)}"
        raise InvalidInput(msg, field=f"{name}.mode")
    return MapYaml(
        image=image,
        resolution=resolution,
        origin=origin,
        negate=bool(negate),
        occupied_thresh=thresholds["occupied_thresh"],
        free_thresh=thresholds["free_thresh"],
        mode=mode,
    )


def image_size(data: bytes, *, name: str = "image") -> tuple[int, int]:
    """``(width, height)`` of an image from its header, without decoding its pixels (a size
    check before the work)."""
    with _open_image(data, name) as image:
        return int(image.width), int(image.height)


def _open_image(data: bytes, name: str) -> Image.Image:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            return Image.open(io.BytesIO(data))
    except (UnidentifiedImageError, OSError, ValueError, Image.DecompressionBombError) as exc:
        head = quote(bytes(data[:16]))
        msg = f"{name} is not an image Pillow can read (first bytes {head}): {quote(str(exc))}"
        raise InvalidInput(msg, field=name) from None


def decode_map_image(data: bytes, meta: MapYaml, *, name: str = "image") -> RobotMap:
    """Decode an occupancy image as ``map_server`` does, in numpy: a pixel's shade is the mean
    of its colour channels (in ``trinary`` mode with an alpha channel, the alpha too: opaque
    counts as white), ``p = 1 - shade`` (``shade`` with ``negate``); ``trinary``: 100 if
    ``p > occupied_thresh``, 0 if ``p < free_thresh``, else -1; ``scale``: the same, with the
    values between scaled to 1..99 and any pixel not fully opaque unknown; ``raw``: the value
    ``round(shade * 255)`` if it is in 0..100, else -1."""
    try:
        with _open_image(data, name) as image, warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            image.load()
            channels, alpha, top = _channels(image)
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:
        msg = f"{name} does not decode: {quote(str(exc))}"
        raise InvalidInput(msg, field=name) from None
    if alpha is not None and meta.mode == "trinary":
        channels = np.concatenate([channels, alpha[..., None]], axis=2)
    shade = channels.sum(axis=2, dtype=np.float64) / channels.shape[2] / top
    occ = shade if meta.negate else 1.0 - shade
    out = np.full(shade.shape, -1, dtype=np.int8)
    occupied = meta.occupied_thresh < occ
    free = occ < meta.free_thresh
    if meta.mode == "raw":
        value = np.floor(shade * 255 + 0.5)  # std::round: shade * 255 is never negative
        inside = value <= 100
        out[inside] = value[inside].astype(np.int8)
    else:
        out[free] = 0
        out[occupied] = 100
        if meta.mode == "scale":
            between = ~free & ~occupied
            scaled = np.rint(
                (occ - meta.free_thresh) / (meta.occupied_thresh - meta.free_thresh) * 100
            )
            out[between] = scaled[between].astype(np.int8)
            if alpha is not None:
                out[alpha != top] = -1
    H, W = out.shape
    return RobotMap(out, MapFrame((H, W), meta.resolution, meta.origin))


def _channels(
    image: Image.Image,
) -> tuple[npt.NDArray[Any], npt.NDArray[Any] | None, float]:
    """(H x W x C colour channels, the alpha channel or None, the channels' full scale)."""
    if image.mode in ("I;16", "I;16B", "I;16L", "I;16N", "I"):
        grey = np.asarray(image).astype(np.float64)
        # 16-bit greys (a PGM with maxval 65535 opens as "I" in recent Pillow) span 0..65535.
        top = 65535.0 if grey.max() <= 65535 else float(grey.max())
        return grey[..., None], None, top
    has_alpha = image.mode in ("LA", "La", "PA", "RGBA", "RGBa") or "transparency" in image.info
    if image.mode == "L":
        return np.asarray(image)[..., None], None, 255.0
    if image.mode == "LA":  # grey counts three times, as red, green and blue
        arr = np.asarray(image)
        return np.repeat(arr[..., :1], 3, axis=2), arr[..., 1], 255.0
    rgb = np.asarray(image.convert("RGBA" if has_alpha else "RGB"))
    if has_alpha:
        return rgb[..., :3], rgb[..., 3], 255.0
    return rgb, None, 255.0


def parse_ros_map(yaml_text: str | bytes, image: bytes) -> RobotMap:
    """A ROS map from its YAML text and the bytes of the image it describes."""
    return decode_map_image(image, parse_map_yaml(yaml_text))


def read_ros_map(path: str | os.PathLike[str]) -> RobotMap:
    """Read a ROS ``map_server`` map: the YAML file and the image it names (relative to the
    YAML's folder unless absolute)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InvalidInput(f"map file {str(p)!r} does not exist", field="map") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InvalidInput(f"map file {str(p)!r} cannot be read: {exc}", field="map") from None
    meta = parse_map_yaml(text)
    if not meta.image:
        raise InvalidInput(
            f"{p.name} names no image file ('image' is missing or empty)", field="yaml.image"
        )
    image_path = p.parent / meta.image
    try:
        data = image_path.read_bytes()
    except FileNotFoundError:
        msg = f"the image file {str(image_path)!r} named in {p.name} does not exist"
        raise InvalidInput(msg, field="yaml.image") from None
    except OSError as exc:
        msg = f"the image file {str(image_path)!r} named in {p.name} cannot be read: {exc}"
        raise InvalidInput(msg, field="yaml.image") from None
    return decode_map_image(data, meta, name=str(image_path))

"""ROS ``map_server`` maps: the YAML and the image it names, decoded to occupancy exactly as
Nav2's ``map_server`` (``map_io.cpp``, ``loadMapFromFile``) does, vectorised."""

from __future__ import annotations

import io
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import yaml
from PIL import Image, UnidentifiedImageError

from planner.errors import QUOTE_LIMIT, InvalidInput, quote
from planner.maps.frames import framed, origin_of, resolution_of
from planner.maps.robot_maps import RobotMap
from planner.parsing import number

__all__ = [
    "DEFAULT_FREE_THRESH",
    "DEFAULT_OCCUPIED_THRESH",
    "MAX_YAML_BYTES",
    "MAX_YAML_DEPTH",
    "MapMode",
    "MapYaml",
    "decode_map_image",
    "image_size",
    "parse_map_yaml",
    "parse_ros_map",
    "read_ros_map",
]

MapMode = Literal["trinary", "scale", "raw"]

#: map_server's customary thresholds, used when a YAML leaves them out.
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196


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


MAX_YAML_BYTES = 65536
"""Bytes of a map YAML at most (a map_server YAML is seven keys, a few hundred bytes)."""
MAX_YAML_DEPTH = 8
"""Collections nested at most this deep in a map YAML (its deepest value, ``origin``, is 2)."""


class _MapYamlLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses aliases (``*name``) and nesting beyond
    :data:`MAX_YAML_DEPTH` as it composes: a map YAML needs neither, and aliases are how a few
    hundred bytes expand into billions of values (the "billion laughs"). Refusing them is
    simpler and stricter than counting the nodes they would expand to."""

    field = "yaml"
    _depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            event = self._next()
            msg = (
                f"{self.field} uses an alias (*{quote(event.anchor, 40)[1:-1]}, line "
                f"{event.start_mark.line + 1}); a map YAML is plain keys and values: aliases "
                "are refused"
            )
            raise InvalidInput(msg, field=self.field)
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                msg = (
                    f"{self.field} nests deeper than {MAX_YAML_DEPTH} levels (line "
                    f"{self._next().start_mark.line + 1}); a map YAML is plain keys and values"
                )
                raise InvalidInput(msg, field=self.field)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def _next(self) -> Any:
        return self.peek_event()  # type: ignore[no-untyped-call]


def parse_map_yaml(text: str | bytes, *, name: str = "yaml") -> MapYaml:
    """Read a map YAML (safe YAML, without aliases, at most :data:`MAX_YAML_BYTES` and
    :data:`MAX_YAML_DEPTH` deep): ``image``, ``resolution``, ``origin`` required;
    ``negate`` (0), ``occupied_thresh`` (0.65), ``free_thresh`` (0.196), ``mode`` (trinary).

    >>> meta = parse_map_yaml("image: m.pgm\\nresolution: 0.05\\norigin: [-1, 2, 0]\\nmode: scale")
    >>> meta.origin, meta.negate, meta.occupied_thresh, meta.free_thresh, meta.mode
    ((-1.0, 2.0, 0.0), False, 0.65, 0.196, 'scale')
    >>> parse_map_yaml("resolution: 0.05\\norigin: [0, 0, 0]\\nmode: colour")
    Traceback (most recent call last):
    ...
    planner.errors.InvalidInput: yaml.mode must be trinary, scale or raw; got 'colour'
    """
    if len(text) > MAX_YAML_BYTES:
        msg = f"{name} has {len(text)} bytes; a map YAML may have {MAX_YAML_BYTES} at most"
        raise InvalidInput(msg, field=name)
    try:
        loader = _MapYamlLoader(text)  # bytes are decoded here: not UTF-8 is a YAMLError too
        loader.field = name
        try:
            doc = loader.get_single_data()
        finally:
            loader.dispose()
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
    resolution = resolution_of(doc["resolution"], f"{name}.resolution")
    origin = origin_of(doc["origin"], f"{name}.origin")
    negate = doc.get("negate", 0)
    if negate not in (0, 1) or not isinstance(negate, int):  # bool is an int too
        msg = f"{name}.negate must be 0 or 1; got {quote(negate)}"
        raise InvalidInput(msg, field=f"{name}.negate")
    thresholds = {}
    for key, default in (
        ("occupied_thresh", DEFAULT_OCCUPIED_THRESH),
        ("free_thresh", DEFAULT_FREE_THRESH),
    ):
        value = number(doc.get(key, default), f"{name}.{key}")
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
    check before the work). An image over Pillow's own pixel limit is refused here, with the
    code ``TOO_LARGE``, as any other image too large."""
    with _open_image(data, name) as image:
        return int(image.width), int(image.height)


def _open_image(data: bytes, name: str) -> Image.Image:
    try:
        return Image.open(io.BytesIO(data))
    except Image.DecompressionBombError:
        # Pillow's refusal from the header, before any pixel is decoded (its message states
        # the pixels and the limit): the image is too large, not malformed.
        limit = 2 * (Image.MAX_IMAGE_PIXELS or 0)
        msg = f"{name}: its header gives over {limit} pixels, more than any map may have"
        raise InvalidInput(msg, field=name, code="TOO_LARGE") from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        # Pillow's message names the file object (an address): say what it could not do.
        why = "not a format Pillow reads" if isinstance(exc, UnidentifiedImageError) else exc
        head = quote(bytes(data[:16]))
        msg = (
            f"{name} is not an image Pillow can read (first bytes {head}): {_reason(why)}; "
            "send the map's PGM, PNG or BMP"
        )
        raise InvalidInput(msg, field=name) from None


def _reason(exc: object) -> str:
    """An exception's text without object reprs (``<_io.BytesIO object at 0x...>``)."""
    return _OBJECT_REPR.sub("the data", str(exc))[:QUOTE_LIMIT]


_OBJECT_REPR = re.compile(r"<[^<>]*? at 0x[0-9a-fA-F]+>")

# Pillow warns of images past its pixel limit (89 M pixels; it refuses those past twice that,
# ``TOO_LARGE`` above): a map that large is a map, not a decompression bomb, and the service
# sizes every image from its header against its own limit before decoding. A filter set once,
# not ``warnings.catch_warnings()`` round each decode: that saves and restores the process's
# filters from worker threads, undoing another thread's (FastAPI's) meanwhile.
warnings.filterwarnings("ignore", category=Image.DecompressionBombWarning)


def decode_map_image(data: bytes, meta: MapYaml, *, name: str = "image") -> RobotMap:
    """Decode an occupancy image as ``map_server`` does, in numpy: a pixel's shade is the mean
    of its colour channels (in ``trinary`` mode with an alpha channel, the alpha too: opaque
    counts as white), ``p = 1 - shade`` (``shade`` with ``negate``); ``trinary``: 100 if
    ``p > occupied_thresh``, 0 if ``p < free_thresh``, else -1; ``scale``: the same, with the
    values between scaled to 1..99 and any pixel not fully opaque unknown; ``raw``: the value
    ``round(shade * 255)`` if it is in 0..100, else -1."""
    fields = ("yaml.resolution", "yaml.origin")
    try:
        with _open_image(data, name) as image:
            frame = framed((image.height, image.width), meta.resolution, meta.origin, fields=fields)
            scaled = _netpbm_scaled(data, image, name)
            if scaled is None:
                image.load()
                channels, alpha, top = _channels(image)
            else:
                (channels, top), alpha = scaled, None
    except InvalidInput:
        raise  # a ValueError too: already says what is wrong
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:
        msg = f"{name} does not decode: {_reason(exc)}"
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
    return RobotMap(out, frame)


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


_NETPBM_TOKEN = re.compile(rb"(?:\s|#[^\r\n]*[\r\n])*(\S+)")


def _netpbm_scaled(
    data: bytes, image: Image.Image, name: str
) -> tuple[npt.NDArray[Any], float] | None:
    """A binary PGM or PPM whose ``maxval`` is neither 255 nor 65535, read as its values and
    that ``maxval`` (the full scale): Pillow rescales such values one by one in Python, and
    clips silently those above ``maxval``, which the format forbids. A value above it is
    refused, naming both. ``None`` for any other image (Pillow decodes it)."""
    if image.format != "PPM" or data[:2] not in (b"P5", b"P6"):
        return None
    tokens, at = [], 2
    for _ in range(3):  # width, height, maxval; comments between them
        match = _NETPBM_TOKEN.match(data, at)
        if match is None:
            return None  # Pillow opened it: it says why it cannot decode it
        tokens.append(match.group(1))
        at = match.end()
    maxval = int(tokens[2])
    if maxval in (255, 65535):
        return None
    bands = 1 if data[:2] == b"P5" else 3
    H, W = image.height, image.width
    count = H * W * bands
    dtype = np.dtype(np.uint8 if maxval < 256 else ">u2")
    raster = data[at + 1 : at + 1 + count * dtype.itemsize]  # one whitespace after maxval
    if len(raster) < count * dtype.itemsize:
        raise InvalidInput(f"{name} does not decode: its pixels end early", field=name)
    values: npt.NDArray[Any] = np.frombuffer(raster, dtype=dtype).reshape(H, W, bands)
    over = np.argwhere(values > maxval)
    if over.size:
        r, c, b = (int(v) for v in over[0])
        msg = (
            f"{name} has value {int(values[r, c, b])} at row {r}, column {c}, above its "
            f"maxval {maxval}: a PGM's values go from 0 to maxval"
        )
        raise InvalidInput(msg, field=name)
    return values, float(maxval)


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

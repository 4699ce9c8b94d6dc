"""A map's limits: frames whose cells would not all have finite centers, images over Pillow's
pixel limit, and PGM values above their ``maxval``; each refused naming the field."""

from __future__ import annotations

import io
import math
import struct
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

import planner
from planner import InvalidInput
from planner.maps.frames import MAX_EXTENT, MAX_RESOLUTION, MIN_RESOLUTION
from planner.maps.ros_maps import MapYaml

GRID = [[0] * 6 for _ in range(6)]
OCCUPANCY_GRID: dict[str, Any] = {
    "info": {
        "resolution": 0.05,
        "width": 2,
        "height": 1,
        "origin": {"position": {"x": 0.0, "y": 0.0}},
    },
    "data": [0, 100],
}


@pytest.mark.parametrize(
    ("frame", "field", "said"),
    [
        ({"resolution": 1e308}, "resolution", "0.0001 to 1000 meters per cell"),
        ({"resolution": 1e-300}, "resolution", "got 1e-300"),
        ({"resolution": 5e-324}, "resolution", "got 5e-324"),
        ({"origin": [1e308, 1e308, 0]}, "origin", "10,000,000 m"),
        ({"origin": [0, -1e7, 0]}, "origin", "10,000,000 m"),  # the corner beyond it
        ({"origin": [0, 0, 1e308]}, None, None),  # any yaw keeps the corners in reach
    ],
)
def test_an_extreme_frame_is_refused_naming_its_field(
    frame: dict[str, object], field: str | None, said: str | None
) -> None:
    if field is None:
        robot_map = planner.grid_map(GRID, **frame)  # type: ignore[arg-type]
        assert np.isfinite(robot_map.frame.centers(np.argwhere(np.ones((6, 6))))).all()
        return
    with pytest.raises(InvalidInput, match=said) as info:
        planner.grid_map(GRID, **frame)  # type: ignore[arg-type]
    assert info.value.field == field


def test_the_bounds_themselves_are_accepted_and_every_center_is_finite() -> None:
    for resolution in (MIN_RESOLUTION, MAX_RESOLUTION):
        planner.grid_map(GRID, resolution=resolution)
    # The farthest corner exactly at the bound, at a yaw that points it there.
    span = math.hypot(6, 6) * MAX_RESOLUTION
    origin = [-(MAX_EXTENT - span), MAX_EXTENT - span, math.pi / 4]
    robot_map = planner.grid_map(GRID, resolution=MAX_RESOLUTION, origin=origin)
    centers = robot_map.frame.centers(np.argwhere(np.ones((6, 6))))
    assert np.isfinite(centers).all()
    assert np.abs(centers).max() <= MAX_EXTENT
    with pytest.raises(InvalidInput, match="origin") as info:
        planner.grid_map(GRID, resolution=MAX_RESOLUTION, origin=[origin[0] - 1, 0, 0])
    assert info.value.field == "origin"


def test_a_map_too_wide_for_its_resolution_names_the_resolution() -> None:
    big = {**OCCUPANCY_GRID, "info": {**OCCUPANCY_GRID["info"], "width": 20000, "height": 1}}
    big["info"]["resolution"] = 1000.0
    with pytest.raises(InvalidInput, match="20000") as info:
        planner.occupancy_grid_map(big)
    assert info.value.field == "occupancy_grid.info.resolution"


@pytest.mark.parametrize(
    ("info", "field"),
    [
        ({"resolution": 1e-300}, "occupancy_grid.info.resolution"),
        ({"resolution": 1e308}, "occupancy_grid.info.resolution"),
        (
            {"origin": {"position": {"x": 1e308, "y": 1e308}}},
            "occupancy_grid.info.origin",
        ),
    ],
)
def test_an_occupancy_grid_with_an_extreme_frame_is_refused(
    info: dict[str, object], field: str
) -> None:
    message = {**OCCUPANCY_GRID, "info": {**OCCUPANCY_GRID["info"], **info}}
    with pytest.raises(InvalidInput) as raised:
        planner.occupancy_grid_map(message)
    assert raised.value.field == field


def test_a_ros_map_with_an_extreme_frame_is_refused(tmp_path: Path) -> None:
    image = b"P5 2 2 255\n" + bytes([0, 255, 255, 0])
    for text, field in [
        ("image: m.pgm\nresolution: 1e-300\norigin: [0, 0, 0]\n", "yaml.resolution"),
        ("image: m.pgm\nresolution: 0.05\norigin: [1e308, 0, 0]\n", "yaml.origin"),
        ("image: m.pgm\nresolution: 1000\norigin: [9999000, 0, 0]\n", "yaml.origin"),
    ]:
        with pytest.raises(InvalidInput) as info:
            planner.parse_ros_map(text, image)
        assert info.value.field == field, text


def _png_header(width: int, height: int) -> bytes:
    """A PNG's signature and header chunk, no pixels: its size is all it says."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")


def test_an_image_over_pillows_limit_is_too_large_from_its_header() -> None:
    meta = MapYaml(image="m.png", resolution=0.05, origin=(0.0, 0.0, 0.0))
    for size in (20000, 100000):
        for call in (planner.image_size, lambda data: planner.decode_map_image(data, meta)):
            with pytest.raises(InvalidInput) as info:
                call(_png_header(size, size))
            assert info.value.code == "TOO_LARGE"
            assert info.value.field == "image"


def _pgm(maxval: int, values: list[int], width: int = 2, magic: bytes = b"P5") -> bytes:
    height = len(values) // width // (3 if magic == b"P6" else 1)
    dtype = ">u2" if maxval > 255 else "u1"
    header = b"%s\n# a comment\n%d %d\n%d\n" % (magic, width, height, maxval)
    return header + np.asarray(values, dtype=dtype).tobytes()


@pytest.mark.parametrize(
    ("maxval", "values", "magic", "bad"),
    [
        (100, [0, 255, 100, 0], b"P5", 255),
        (100, [0, 101, 100, 0], b"P5", 101),
        (1000, [0, 1001, 1000, 0], b"P5", 1001),
        (200, [0, 0, 0, 201, 0, 0], b"P6", 201),
    ],
)
def test_a_pgm_value_above_its_maxval_is_refused(
    maxval: int, values: list[int], magic: bytes, bad: int
) -> None:
    text = "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
    with pytest.raises(InvalidInput) as info:
        planner.parse_ros_map(text, _pgm(maxval, values, 1 if magic == b"P6" else 2, magic))
    message = str(info.value)
    assert f"value {bad}" in message
    assert f"maxval {maxval}" in message
    assert info.value.field == "image"


@pytest.mark.parametrize("maxval", [1, 100, 254, 256, 1000, 4095])
def test_a_pgm_of_any_maxval_reads_as_its_shades(maxval: int) -> None:
    """Each value ``v`` is the shade ``v / maxval``: occupied below ``1 - 0.65``, free above
    ``1 - 0.196`` (map_server's trinary rule), as a PGM of maxval 255 with the same shades."""
    rng = np.random.default_rng(maxval)
    values = rng.integers(0, maxval + 1, size=64).tolist()
    text = "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
    got = planner.parse_ros_map(text, _pgm(maxval, values, 8)).occupancy
    shade = np.asarray(values, dtype=np.float64).reshape(8, 8) / maxval
    expected = np.where(1 - shade > 0.65, 100, np.where(1 - shade < 0.196, 0, -1))
    assert got.tolist() == expected.tolist()


def test_image_errors_name_no_object() -> None:
    """Pillow's messages name the file object it read (``<_io.BytesIO object at 0x...>``)."""
    meta = MapYaml(image="m.png", resolution=0.05, origin=(0.0, 0.0, 0.0))
    full = io.BytesIO()
    Image.effect_noise((64, 64), 60).convert("L").save(full, format="PNG")
    cut = full.getvalue()[: len(full.getvalue()) // 2]
    messages = []
    for data in (b"garbage!!", b"", cut, b"P5 2 2 255\n", b"BM" + b"\0" * 40):
        with pytest.raises(InvalidInput) as info:
            planner.decode_map_image(data, meta)
        messages.append(str(info.value))
    assert not [m for m in messages if "object at 0x" in m], messages

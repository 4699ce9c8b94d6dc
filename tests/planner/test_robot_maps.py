"""Robot maps: ROS YAML + image as map_server reads them, OccupancyGrid, framed grids, the frame,
the content hash and every bad map."""

from __future__ import annotations

import io
import math
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

import planner
from planner import InvalidInput
from planner.maps.robot_maps import MapFrame
from tests import naive
from tests.conftest import ROS_MAP_NAMES


def png(array: np.ndarray, mode: str | None = None) -> bytes:
    out = io.BytesIO()
    Image.fromarray(array, mode).save(out, format="PNG")
    return out.getvalue()


YAML = "image: m.png\nresolution: 0.05\norigin: [1.0, -2.0, 0.0]\n"


@pytest.mark.parametrize("name", ROS_MAP_NAMES)
def test_ros_maps_match_a_pixel_by_pixel_parse(ros: Path, name: str) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    meta = planner.parse_map_yaml((ros / f"{name}.yaml").read_text())
    with Image.open(ros / meta.image) as image:
        expected = naive.ros_occupancy(
            image,
            mode=meta.mode,
            negate=meta.negate,
            occupied_thresh=meta.occupied_thresh,
            free_thresh=meta.free_thresh,
        )
    assert robot_map.occupancy.shape == expected.shape
    assert robot_map.free_cells() == int(np.count_nonzero((expected >= 0) & (expected < 65)))
    assert robot_map.occupied_cells() == int(np.count_nonzero(expected >= 65))
    assert robot_map.unknown_cells == int(np.count_nonzero(expected == -1))
    np.testing.assert_array_equal(robot_map.occupancy, expected)
    assert robot_map.resolution == meta.resolution
    assert robot_map.origin == meta.origin


@pytest.mark.parametrize("name", ROS_MAP_NAMES)
def test_one_map_one_id_whichever_way_it_comes(ros: Path, name: str) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    meta = planner.parse_map_yaml((ros / f"{name}.yaml").read_bytes())
    uploaded = planner.parse_ros_map(
        (ros / f"{name}.yaml").read_bytes(), (ros / meta.image).read_bytes()
    )
    message = robot_map.to_occupancy_grid()
    assert (
        message["data"][: robot_map.shape[1]] == robot_map.occupancy[-1].tolist()
    )  # row 0: bottom
    as_message = planner.occupancy_grid_map(message)
    assert uploaded.map_id == robot_map.map_id == as_message.map_id
    np.testing.assert_array_equal(as_message.occupancy, robot_map.occupancy)
    assert as_message.origin == pytest.approx(robot_map.origin)
    if set(np.unique(robot_map.occupancy).tolist()) <= {-1, 0, 100}:
        grid = np.where(robot_map.occupancy == 100, 1, robot_map.occupancy)
        framed = planner.grid_map(grid, resolution=meta.resolution, origin=list(meta.origin))
        assert framed.map_id == robot_map.map_id


def test_other_content_or_frame_other_id() -> None:
    base = planner.grid_map([[0, 1], [0, -1]], resolution=0.05, origin=[0, 0, 0])
    others = [
        planner.grid_map([[0, 1], [0, 0]], resolution=0.05),
        planner.grid_map([[0, 1], [0, -1]], resolution=0.1),
        planner.grid_map([[0, 1], [0, -1]], resolution=0.05, origin=[0, 0, 0.5]),
        planner.grid_map([[0, 1, 0, -1]], resolution=0.05),
    ]
    assert len({base.map_id, *(m.map_id for m in others)}) == 5


def test_a_plain_grid_keeps_its_historical_id() -> None:
    import hashlib

    grid = np.array([[0, 1, 0], [0, 0, 1]], dtype=np.uint8)
    expected = hashlib.sha256(b"2x3:" + grid.tobytes()).hexdigest()
    assert planner.grid_map(grid).map_id == expected
    assert planner.grid_map(grid, resolution=0.5).map_id != expected


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
@pytest.mark.parametrize("negate", [0, 1])
@pytest.mark.parametrize("colour", ["L", "LA", "RGB", "RGBA"])
def test_pixels_as_map_server_reads_them(mode: str, negate: int, colour: str) -> None:
    rng = np.random.default_rng(len(mode) + negate + len(colour))
    channels = {"L": 1, "LA": 2, "RGB": 3, "RGBA": 4}[colour]
    pixels = rng.integers(0, 256, size=(9, 11, channels), dtype=np.uint8)
    pixels[0, :, :] = np.arange(11, dtype=np.uint8)[:, None] * 10  # 0..100 for raw
    if colour in ("LA", "RGBA"):
        pixels[1::2, :, -1] = 255  # half the rows opaque
    data = png(pixels[..., 0] if channels == 1 else pixels, colour)
    text = f"{YAML}mode: {mode}\nnegate: {negate}\noccupied_thresh: 0.6\nfree_thresh: 0.3\n"
    robot_map = planner.parse_ros_map(text, data)
    with Image.open(io.BytesIO(data)) as image:
        expected = naive.ros_occupancy(
            image, mode=mode, negate=bool(negate), occupied_thresh=0.6, free_thresh=0.3
        )
    np.testing.assert_array_equal(robot_map.occupancy, expected)


def test_a_large_image_parses_fast() -> None:
    rng = np.random.default_rng(0)
    pixels = rng.choice(np.array([0, 205, 254], dtype=np.uint8), size=(1100, 1600))
    data = png(pixels)
    planner.parse_ros_map(YAML, data)  # warm the imports
    t0 = time.perf_counter()
    robot_map = planner.parse_ros_map(YAML, data)
    elapsed = time.perf_counter() - t0
    assert robot_map.shape == (1100, 1600)
    assert elapsed < 1.0, f"{elapsed:.2f} s for 1.76 M pixels"


def test_image_size_reads_only_the_header() -> None:
    data = png(np.zeros((300, 500), dtype=np.uint8))
    header = data[:64]  # the pixels are not there: only the header can answer
    assert planner.image_size(header) == (500, 300)
    with pytest.raises(InvalidInput, match="image does not decode") as info:
        planner.parse_ros_map(YAML, header)
    assert info.value.field == "image"


BAD_YAML = [
    ("- a\n- b\n", "yaml", "['a', 'b']"),
    ("just text", "yaml", "'just text'"),
    ("image: m.png\norigin: [0, 0, 0]\n", "yaml.resolution", "no 'resolution'"),
    ("image: m.png\nresolution: 0.05\n", "yaml.origin", "no 'origin'"),
    ("resolution: 0\norigin: [0, 0, 0]\n", "yaml.resolution", "got 0"),
    ("resolution: -0.05\norigin: [0, 0, 0]\n", "yaml.resolution", "got -0.05"),
    ("resolution: .nan\norigin: [0, 0, 0]\n", "yaml.resolution", "nan"),
    ("resolution: .inf\norigin: [0, 0, 0]\n", "yaml.resolution", "inf"),
    ("resolution: fine\norigin: [0, 0, 0]\n", "yaml.resolution", "'fine'"),
    ("resolution: 0.05\norigin: [0, 0]\n", "yaml.origin", "[0, 0]"),
    ("resolution: 0.05\norigin: [0, 0, 0]\nmode: colour\n", "yaml.mode", "'colour'"),
    ("resolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 1.5\n", "yaml.occupied_thresh", "1.5"),
    ("resolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: -0.1\n", "yaml.free_thresh", "-0.1"),
    (
        "resolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.7\noccupied_thresh: 0.6\n",
        "yaml.free_thresh",
        "0.7",
    ),
    (
        "resolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.6\noccupied_thresh: 0.6\n",
        "yaml.free_thresh",
        "0.6",
    ),
    ("resolution: 0.05\norigin: [0, 0, 0]\nnegate: 2\n", "yaml.negate", "2"),
    ("resolution: 0.05\norigin: [0, 0, 0\n", "yaml", "not valid YAML"),
]


@pytest.mark.parametrize(("text", "field", "quoted"), BAD_YAML)
def test_bad_yaml_names_the_key_and_value(text: str, field: str, quoted: str) -> None:
    with pytest.raises(InvalidInput) as info:
        planner.parse_ros_map(text, png(np.zeros((2, 2), dtype=np.uint8)))
    assert info.value.field == field
    assert quoted in str(info.value)


def test_quoted_values_are_cut_short() -> None:
    with pytest.raises(InvalidInput) as info:
        planner.parse_map_yaml(f"resolution: '{'x' * 5000}'\norigin: [0, 0, 0]\n")
    assert len(str(info.value)) < 200


def alias_bomb(levels: int = 9) -> str:
    """The "billion laughs" as a map YAML: ``levels`` lists of 9 aliases of the one before
    (nine levels: 479 bytes, 9**9 strings once expanded)."""
    lines = ["image: m.pgm", "resolution: 0.05", "origin: [0, 0, 0]"]
    lines.append('a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]')
    names = "abcdefghijklmnopqrstuvwxyz"
    for i in range(1, levels):
        prev, name = names[i - 1], names[i]
        lines.append(f"{name}: &{name} [{','.join([f'*{prev}'] * 9)}]")
    lines.append(f"mode: *{names[levels - 1]}")
    return "\n".join(lines) + "\n"


def test_a_yaml_alias_bomb_is_refused_without_expanding() -> None:
    text = alias_bomb()
    assert len(text) < 600
    with pytest.raises(InvalidInput, match=r"alias \(\*a, line 5\).*aliases are refused") as info:
        planner.parse_map_yaml(text)
    assert info.value.field == "yaml"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("origin: " + "[" * 5000 + "]" * 5000 + "\n", "nests deeper than 8 levels"),
        ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n#" + "x" * 70000, "65536 at most"),
    ],
)
def test_a_deep_or_long_yaml_is_refused(text: str, match: str) -> None:
    with pytest.raises(InvalidInput, match=match):
        planner.parse_map_yaml(text)


def test_a_yaml_that_is_not_text_is_refused() -> None:
    with pytest.raises(InvalidInput, match="yaml is not valid YAML") as info:
        planner.parse_map_yaml(png(np.zeros((1, 1), dtype=np.uint8)))
    assert info.value.field == "yaml"


def test_an_anchor_without_alias_still_reads() -> None:
    meta = planner.parse_map_yaml("image: &i m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    assert meta.image == "m.pgm"


def test_an_image_that_does_not_decode() -> None:
    with pytest.raises(InvalidInput, match="not an image") as info:
        planner.parse_ros_map(YAML, b"P5 this is not a picture")
    assert info.value.field == "image"


def grid_message(**change: object) -> dict[str, object]:
    message = planner.grid_map([[0, 1, -1], [0, 0, 0]], resolution=0.1).to_occupancy_grid()
    message.update(change)
    return message


@pytest.mark.parametrize(
    ("message", "field", "quoted"),
    [
        (grid_message(data=[0] * 5), "occupancy_grid.data", "5 values"),
        (grid_message(data=[0, 0, 0, 0, 0, 101]), "occupancy_grid.data", "101"),
        (grid_message(data=[0, 0, 0, -2, 0, 0]), "occupancy_grid.data", "-2"),
        (grid_message(data=[0, 0, 0, "x", 0, 0]), "occupancy_grid.data", "'x'"),
        (grid_message(data=[0.5] * 6), "occupancy_grid.data", "0.5"),
        ({"data": [0]}, "occupancy_grid.info", "no 'info'"),
        (
            grid_message(info={"width": 3, "height": 2, "origin": {"position": {}}}),
            "occupancy_grid.info.resolution",
            "no 'resolution'",
        ),
        (
            grid_message(
                info={"width": 3, "height": 2, "resolution": 0, "origin": {"position": {}}}
            ),
            "occupancy_grid.info.resolution",
            "got 0",
        ),
        (
            grid_message(
                info={"width": 0, "height": 2, "resolution": 1, "origin": {"position": {}}}
            ),
            "occupancy_grid.info.width",
            "got 0",
        ),
        ([1, 2], "occupancy_grid", "[1, 2]"),
        (
            grid_message(
                info={"width": 3, "height": 2, "resolution": 1, "origin": {"position": {"X": 1.0}}}
            ),
            "occupancy_grid.info.origin.position.X",
            "no field 'X' (it takes x, y, z)",
        ),
        (
            grid_message(
                info={
                    "width": 3,
                    "height": 2,
                    "resolution": 1,
                    "origin": {"position": {}, "orientation": {"yaw": 1}},
                }
            ),
            "occupancy_grid.info.origin.orientation.yaw",
            "no field 'yaw' (it takes x, y, z, w)",
        ),
    ],
)
def test_bad_occupancy_grids(message: object, field: str, quoted: str) -> None:
    with pytest.raises(InvalidInput) as info:
        planner.occupancy_grid_map(message)
    assert info.value.field == field
    assert quoted in str(info.value)


def test_bad_grids() -> None:
    with pytest.raises(InvalidInput, match="found 2 at"):
        planner.grid_map([[0, 2]])
    with pytest.raises(InvalidInput, match=r"resolution must be 0\.0001 to 1000") as info:
        planner.grid_map([[0]], resolution=-1)
    assert info.value.field == "resolution"


def test_a_missing_image_file_is_named(tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text("image: gone.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(InvalidInput, match=r"gone\.pgm") as info:
        planner.read_ros_map(tmp_path / "m.yaml")
    assert "does not exist" in str(info.value)
    with pytest.raises(InvalidInput, match=r"nothing\.yaml"):
        planner.read_ros_map(tmp_path / "nothing.yaml")


# The frame


def test_testmap_centers_follow_the_formula_with_yaw(ros: Path) -> None:
    robot_map = planner.read_ros_map(ros / "testmap.yaml")
    assert robot_map.origin == (2.0, 3.0, 1.0)
    cells = np.argwhere(np.ones(robot_map.shape, dtype=bool))
    centers = robot_map.frame.centers(cells)
    for (r, c), (x, y) in zip(cells.tolist(), centers.tolist(), strict=True):
        assert (x, y) == pytest.approx(
            naive.cell_center(robot_map.shape, 0.1, (2.0, 3.0, 1.0), r, c)
        )
    np.testing.assert_array_equal(robot_map.frame.cells(centers), cells)


@given(
    st.integers(1, 30),
    st.integers(1, 30),
    st.floats(0.01, 2.0),
    st.floats(-50, 50),
    st.floats(-50, 50),
    st.floats(-math.pi, math.pi),
    st.floats(0.05, 0.95),
    st.floats(0.05, 0.95),
)
def test_point_cell_round_trip(
    H: int, W: int, res: float, ox: float, oy: float, yaw: float, du: float, dv: float
) -> None:
    frame = MapFrame((H, W), res, (ox, oy, yaw))
    cells = np.argwhere(np.ones((H, W), dtype=bool))
    np.testing.assert_array_equal(frame.cells(frame.centers(cells)), cells)
    # Any point inside a cell (not only its center) belongs to it.
    r, c = H // 2, W // 2
    u, v = (c + du) * res, (H - 1 - r + dv) * res
    x = ox + math.cos(yaw) * u - math.sin(yaw) * v
    y = oy + math.sin(yaw) * u + math.cos(yaw) * v
    assert frame.cell_of({"x": x, "y": y}) == (r, c)


def test_a_point_outside_the_map_is_named() -> None:
    frame = MapFrame((10, 20), 0.05, (-1.0, -1.0, 0.0))
    assert frame.cell_of((-0.999, -0.999)) == (9, 0)
    for point in [(-1.001, 0.0), (0.0, -0.5 - 0.501), {"x": 0.0, "y": 1.0}]:
        with pytest.raises(InvalidInput, match="outside the map") as info:
            frame.cell_of(point, name="start")
        assert info.value.field == "start"
        assert repr(point) in str(info.value)
    with pytest.raises(InvalidInput, match="finite numbers"):
        frame.cell_of((math.nan, 0.0), name="goal")


def test_sixteen_bit_greys_span_their_full_scale() -> None:
    grey = (np.arange(12, dtype=np.uint16).reshape(3, 4) * 5000).astype(np.uint16)
    robot_map = planner.parse_ros_map(YAML, png(grey))
    occ = 1 - grey / 65535
    expected = np.where(occ > 0.65, 100, np.where(occ < 0.196, 0, -1))
    np.testing.assert_array_equal(robot_map.occupancy, expected)

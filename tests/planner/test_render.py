"""The renderer: valid PNG and GIF, the right size, the paper's colours at known cells."""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import planner
from planner.cli import main
from planner.experiment.environments import environment
from planner.maps.robot_maps import grid_map
from planner.render import draw, render_episode, render_map, render_plan
from planner.render_axes import known_window
from planner.render_legend import COLOURS, legend_entries
from tests.conftest import grid_from

CELL = 8

# A corridor one cell wide (a tunnel cell at (2, 3)), a wide opening at its right, a gate (free
# (4, 5) and (5, 4) between blocked (4, 4) and (5, 5)), open room elsewhere.
ROOM = grid_from("""
    ..........
    ..........
    ###.####..
    ..........
    ....#.....
    .....#....
    ..........
""")


def decode(data: bytes) -> Image.Image:
    image = Image.open(io.BytesIO(data))
    image.load()
    return image


def frames(image: Image.Image) -> int:
    return int(getattr(image, "n_frames", 1))


def at(image: Image.Image, cell: Sequence[int]) -> tuple[int, int, int]:
    r, c = cell
    pixel = image.convert("RGB").getpixel((c * CELL + CELL // 2, r * CELL + CELL // 2))
    assert isinstance(pixel, tuple)
    return (int(pixel[0]), int(pixel[1]), int(pixel[2]))


def test_colours_are_the_papers() -> None:
    assert COLOURS["obstacle"] == (0, 0, 0)
    assert COLOURS["tunnel"][0] == 255  # orange
    assert 100 <= COLOURS["tunnel"][1] <= 180
    assert COLOURS["tunnel"][2] == 0
    assert max(COLOURS["path"]) == COLOURS["path"][1] > 120  # green
    assert max(COLOURS["dynamic"]) == COLOURS["dynamic"][2] > 200  # blue
    named = ("free", "obstacle", "tunnel", "gate", "dynamic", "path", "start", "goal", "robot")
    assert len({COLOURS[name] for name in named}) == len(named)


def test_plan_png_colours_at_known_cells() -> None:
    p = planner.plan(ROOM, (0, 0), (6, 9), preset="wide")
    assert p.analysis.state[2, 3] == 2  # the corridor cell is sealed
    image = decode(render_plan(p, dynamic_obstacles=[[6, 0]], cell=CELL, poses=False))
    assert image.format == "PNG"
    assert image.size == (10 * CELL, 7 * CELL)
    assert at(image, (2, 0)) == COLOURS["obstacle"]
    assert at(image, (2, 3)) == COLOURS["tunnel"]
    middle = tuple(p.path[len(p.path) // 2].tolist())
    assert at(image, middle) == COLOURS["path"]
    assert at(image, (6, 0)) == COLOURS["dynamic"]
    assert at(image, (0, 0)) == COLOURS["start"]
    assert at(image, (6, 9)) == COLOURS["goal"]
    assert at(image, (4, 5)) == COLOURS["gate"]  # the line across the gap joins its free cells
    assert at(image, (5, 4)) == COLOURS["gate"]
    assert at(image, (4, 4)) == COLOURS["obstacle"]
    assert at(image, (1, 9)) == COLOURS["free"]


def test_unsealed_tunnels_are_not_orange() -> None:
    p = planner.plan(ROOM, (0, 0), (6, 9), preset="shortest")
    image = decode(render_plan(p, cell=CELL, poses=False))
    assert at(image, (2, 3)) == COLOURS["path"]  # the shortest path takes the corridor


def test_trajectory_green_preview_pale() -> None:
    p = planner.plan(ROOM, (0, 0), (6, 9), preset="wide")
    trail = p.path[:3]
    image = decode(render_plan(p, trajectory=trail, cell=CELL, poses=False))
    assert at(image, tuple(trail[1].tolist())) == COLOURS["path"]
    assert at(image, tuple(p.path[-3].tolist())) == COLOURS["preview"]
    assert at(image, tuple(trail[-1].tolist())) == COLOURS["robot"]


def test_the_poses_are_a_blue_line_over_the_path() -> None:
    p = planner.plan(ROOM, (0, 0), (6, 9), preset="shortest")
    image = decode(render_plan(p, cell=CELL))
    assert at(image, (2, 3)) == COLOURS["poses"]  # straight through the corridor's centers
    pixels = np.asarray(image.convert("RGB")).reshape(-1, 3)
    blue = np.all(pixels == COLOURS["poses"], axis=1).sum()
    assert blue >= len(p.path) * CELL // 2
    without = np.asarray(decode(render_plan(p, cell=CELL, poses=False)).convert("RGB"))
    assert not np.all(without.reshape(-1, 3) == COLOURS["poses"], axis=1).any()


def test_map_png_on_an_environment() -> None:
    analysis = planner.analyse(environment(1, seed=0))
    image = decode(render_map(analysis, cell=3))
    assert image.size == (150, 150)
    rgb = np.asarray(image.convert("RGB"))
    cells = rgb[1::3, 1::3]  # the centre pixel of every cell
    tunnel = analysis.state == 2
    gates = analysis.gate_cells().reshape(-1, 2)
    tunnel[gates[:, 0], gates[:, 1]] = False  # a gate's red line crosses its cells
    assert tunnel.any()
    assert (cells[tunnel] == COLOURS["tunnel"]).all()
    assert (cells[analysis.state == 1] == COLOURS["obstacle"]).all()


def test_heat_map_tints_free_cells() -> None:
    p = planner.plan(ROOM, (0, 0), (6, 9), preset="wide")
    clean = decode(render_map(p.analysis, field="clean", cell=CELL))
    kw = decode(render_plan(p, field="kw", cell=CELL))
    assert at(clean, (3, 5)) != COLOURS["free"]  # next to the wall: penalised
    assert at(kw, (0, 9)) != COLOURS["free"]  # far from the goal
    with pytest.raises(planner.InvalidInput, match="wave"):
        render_map(p.analysis, field="kw")


@pytest.mark.parametrize("cell", [0, 65, 2.5])
def test_rejects_bad_cell_size(cell: object) -> None:
    with pytest.raises(planner.InvalidInput, match="cell must be"):
        draw(planner.analyse([[0]]), cell=cell)  # type: ignore[arg-type]


def test_rejects_cells_outside_the_map() -> None:
    p = planner.plan(ROOM, (0, 0), (6, 9))
    with pytest.raises(planner.InvalidInput, match=r"\[7, 0\] is outside"):
        render_plan(p, dynamic_obstacles=[[7, 0]])


def test_episode_gif_frames_follow_the_robot() -> None:
    episode = planner.simulate(ROOM, (0, 0), (6, 9), dynamic_count=3, seed=2)
    image = decode(render_episode(episode, cell=CELL))
    assert image.format == "GIF"
    assert image.size == (10 * CELL, 7 * CELL)
    assert frames(image) == len(episode.dynamic_obstacles)
    image.seek(frames(image) - 1)
    last = image.convert("RGB")
    assert at(last, (6, 9)) == COLOURS["robot"]  # the robot on the goal
    for r, c in episode.dynamic_obstacles[-1].tolist():
        assert at(last, (r, c)) == COLOURS["dynamic"]


def test_episode_without_record_is_refused() -> None:
    p = planner.plan(ROOM, (0, 0), (6, 9))
    episode = planner.run_episode(p, dynamic_count=1, record=False)
    with pytest.raises(planner.InvalidInput, match="record"):
        render_episode(episode)


def test_render_cli_writes_png_and_gif(tmp_path: Path) -> None:
    png, gif = tmp_path / "env6.png", tmp_path / "env6.gif"
    args = ["render", "env6:2", "--start", "0", "0", "--goal", "49", "49", "--out", str(png)]
    args += ["--animate", str(gif), "--cell", "4", "--field", "clean", "--dynamic-count", "5"]
    assert main(args) == 0
    assert decode(png.read_bytes()).size == (200, 200)
    assert frames(decode(gif.read_bytes())) > 50


def test_robot_maps_get_a_legible_picture_with_a_key(ros: Path) -> None:
    robot_map = planner.read_ros_map(ros / "depot.yaml")
    p = planner.plan(robot_map, (250, 40), (106, 500), robot_radius=0.22)
    image = decode(render_plan(p))
    assert 1000 <= image.width <= 1400  # 2 pixels a cell on a 604-cell-wide map
    assert image.height > 2 * 307  # the key and the scale bar below the map
    small = planner.read_ros_map(ros / "TenByTen.yaml")
    picture = decode(planner.render_map(planner.analyse_map(small)))
    assert picture.width >= 200  # many pixels a cell on a 10 x 10 map
    # The margin, unknown cells and the robot's footprint have colours of their own.
    analysis = p.analysis
    assert analysis.cspace is not None
    r, c = np.argwhere(analysis.cspace.margin)[0]
    at_margin = decode(render_map(analysis, cell=CELL))
    assert at(at_margin, (r, c)) == COLOURS["margin"]
    unknown = planner.grid_map([[0, -1], [0, 0]], resolution=0.5)
    shown = decode(render_map(planner.analyse_map(unknown), cell=CELL))
    assert at(shown, (0, 1)) == COLOURS["unknown"]
    assert len({COLOURS[k] for k in ("margin", "unknown", "obstacle", "free", "tunnel")}) == 5


def test_the_start_shows_round_the_robot_standing_on_it() -> None:
    p = planner.plan(ROOM, (0, 0), (6, 9), preset="wide")
    cell = 24
    image = decode(render_plan(p, trajectory=[[0, 0]], cell=cell, poses=False)).convert("RGB")
    center = cell // 2
    assert image.getpixel((center, center)) == COLOURS["robot"]
    ring = [image.getpixel((x, center)) for x in range(center, cell)]  # out to the cell's edge
    assert ring.count(COLOURS["start"]) >= 3  # a ring round the robot, not hidden under it
    small = decode(render_plan(p, trajectory=[[0, 0]], cell=4, poses=False)).convert("RGB")
    assert small.getpixel((2 + 4, 2)) == COLOURS["start"]


def test_the_legend_names_the_trajectory_and_the_planned_path() -> None:
    keys = dict((label, colour) for colour, label in legend_entries())
    assert keys["path"] == COLOURS["path"]
    assert "planned path" not in keys  # no preview drawn: no key for it
    keys = dict(
        (label, colour) for colour, label in legend_entries(path_label="trajectory", preview=True)
    )
    assert keys["trajectory"] == COLOURS["path"]
    assert keys["planned path"] == COLOURS["preview"]
    assert "path" not in keys
    named = legend_entries(preview=True, named=[((1, 2, 3), "nav2")])
    assert [label for _, label in named][-1] == "nav2"
    assert "path" not in {label for _, label in named}


def test_a_robot_map_is_cropped_to_its_known_part_with_axes_in_meters() -> None:
    """A map 90 % unknown: the picture keeps the known rows and columns (and a margin of 4
    cells), the map's top-left pixel first; the axes below and right of it, in meters."""
    occ = np.full((60, 80), -1, dtype=np.int8)
    occ[20:30, 30:50] = 0
    occ[20, 30:50] = 1
    robot_map = grid_map(occ, resolution=0.1, origin=(-2.0, 1.0, 0.0))
    p = planner.plan(robot_map, (25, 35), (25, 45), robot_radius=0.1)
    assert known_window(p.analysis) == (16, 34, 26, 54)
    whole = draw(p.analysis, cell=4)
    cropped = draw(p.analysis, cell=4, crop=True)
    assert cropped.height < whole.height
    bare = draw(p.analysis, cell=4, crop=True, legend=False)  # no legend: no axes either
    assert bare.size == ((54 - 26) * 4, (34 - 16) * 4)
    assert bare.getpixel((0, 0)) == whole.getpixel((26 * 4, 16 * 4))
    # The axes sit right of and below the map: its pixels are where the bare picture has them.
    assert cropped.getpixel((5 * 4, 8 * 4)) == bare.getpixel((5 * 4, 8 * 4))
    assert cropped.getpixel((bare.width, 10)) != bare.getpixel((bare.width - 1, 10))  # the axis


def test_render_draws_a_ros_map_from_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "depot.png"
    depot = Path(__file__).resolve().parents[2] / "examples" / "maps" / "depot.yaml"
    args = ["render", str(depot), "--start", "40", "20"]
    args += ["--goal", "40", "200", "--param", "robot_radius=0.22", "--out", str(out)]
    assert main(args) == 0
    assert out.read_bytes()[1:4] == b"PNG"

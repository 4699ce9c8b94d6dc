"""Narrow passages: the doors of a built map found exactly (width, place, length), none in open
rooms or dead ends, and the shared ROS maps against a brute-force medial reference."""

from __future__ import annotations

import importlib
import io
import json
import math
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import ndimage

import planner
from planner import InvalidInput, Passage, crossed_passages, find_passages
from planner.analysis.medial import medial_axis
from tests import naive, naive_passages
from tests.doors import GAPS, RESOLUTION, doors_grid, doors_map

RADIUS = 0.2


def door_of(passage: Passage, middles: list[tuple[float, float]]) -> int:
    """The door whose middle is within one cell of the passage's narrowest cell."""
    near = [
        i
        for i, (r, c) in enumerate(middles)
        if abs(passage.row - r) <= 1 and abs(passage.col - c) <= 1
    ]
    assert len(near) == 1, (passage.row, passage.col, middles)
    return near[0]


@pytest.mark.parametrize(
    ("radius", "max_width", "doors"),
    [
        (RADIUS, None, [0.55]),  # default 2 R + 0.3 = 0.7: 0.35 too narrow, 0.75+ wide enough
        (RADIUS, 0.55, []),  # the 0.55 door's width is 0.60: wider than 0.55
        (RADIUS, 0.6, [0.55]),  # the boundary is inclusive: 0.60 wide is at most 0.6
        (RADIUS, 0.65, [0.55]),
        (RADIUS, 0.9, [0.55, 0.75]),
        (RADIUS, 1.1, [0.55, 0.75, 0.95]),
        (RADIUS, 2.0, [0.55, 0.75, 0.95, 1.6]),
        (0.1, 0.7, [0.35, 0.55]),  # a 0.2 m robot fits the 0.35 door (width 0.40)
        (0.3, None, [0.75]),  # a 0.6 m robot does not fit the 0.55 door (width 0.60)
        (0.29, None, [0.55, 0.75]),
    ],
)
def test_doors_of_known_widths(radius: float, max_width: float | None, doors: list[float]) -> None:
    robot_map = doors_map()
    _, middles = doors_grid()
    found = find_passages(robot_map, radius, max_width)
    assert [GAPS[door_of(p, middles)] for p in found] == doors
    W = robot_map.shape[1]
    cs = planner.configuration_space(robot_map, robot_radius=radius)
    widest = max_width if max_width is not None else 2 * radius + 0.3
    for i, p in enumerate(found):
        gap = GAPS[door_of(p, middles)]
        assert p.id == i
        # Center to center: the free gap plus one cell, to within one cell.
        assert abs(p.width_m - (gap + RESOLUTION)) <= RESOLUTION + 1e-9
        assert 2 * radius < p.width_m <= widest + 1e-9
        assert p.width_m == pytest.approx(2 * cs.distance[p.row, p.col] * RESOLUTION)
        (x, y), *_ = robot_map.frame.centers([[p.row, p.col]]).tolist()
        assert (p.x, p.y) == pytest.approx((x, y))
        # Along the door: the wall's thickness and the flare on both sides while the width
        # stays below max_width (sqrt(h^2 + (w/2)^2) < max_width / 2 for h from the wall).
        flare = math.sqrt(max((widest / 2) ** 2 - (p.width_m / 2) ** 2, 0.0))
        assert abs(p.length_m - (0.1 + 2 * flare)) <= 3 * RESOLUTION
        rows, cols = np.divmod(p.cells, W)
        assert p.row * W + p.col in set(p.cells.tolist())
        assert np.all(cs.traversable[rows, cols] == 1)
        # The neck stays by its door: no cell of an open room away from it.
        assert np.all(np.abs(cols - p.col) <= widest / RESOLUTION)
        assert np.all(np.abs(rows - p.row) <= widest / RESOLUTION)


def test_positions_follow_the_frame() -> None:
    grid, _ = doors_grid((0.55,))
    rotated = planner.grid_map(grid, resolution=RESOLUTION, origin=(3.0, -1.0, 0.7))
    (p,) = find_passages(rotated, RADIUS)
    (x, y), *_ = rotated.frame.centers([[p.row, p.col]]).tolist()
    assert (p.x, p.y) == pytest.approx((x, y))
    assert rotated.frame.cell_of((p.x, p.y)) == (p.row, p.col)


def test_unknown_space_is_blocked_but_no_wall() -> None:
    # Walls as a scan draws them: an occupied face, unknown behind it. The same passages.
    grid, _ = doors_grid(wall=0.3)
    solid = find_passages(planner.grid_map(grid, resolution=RESOLUTION), RADIUS, 1.1)
    inside = (grid == 1) & ~ndimage.binary_dilation(grid == 0, structure=np.ones((3, 3)))
    scanned = np.where(inside, -1, grid).astype(np.int8)
    assert (scanned == -1).sum() > 100
    found = find_passages(planner.grid_map(scanned, resolution=RESOLUTION), RADIUS, 1.1)
    assert [(p.row, p.col, p.width_m) for p in found] == [(p.row, p.col, p.width_m) for p in solid]
    # Doors through unknown space: unknown is blocked, but it is no wall.
    assert find_passages(doors_map(unknown_walls=True), RADIUS, 1.1) == ()


def test_a_thick_wall_door_is_found_at_its_middle() -> None:
    grid, middles = doors_grid((0.55,), wall=0.6)
    robot_map = planner.grid_map(grid, resolution=RESOLUTION)
    (p,) = find_passages(robot_map, RADIUS)
    assert abs(p.row - middles[0][0]) <= 1
    assert abs(p.col - middles[0][1]) <= 1
    assert p.width_m == pytest.approx(0.6)
    assert p.length_m >= 0.6


def test_no_passages_in_open_rooms_or_dead_ends() -> None:
    room = np.zeros((60, 80), dtype=np.int8)
    assert find_passages(planner.grid_map(room, resolution=RESOLUTION), RADIUS) == ()
    # A narrow alcove off a room (0.55 m wide, 1 m deep) leads nowhere: not a passage.
    alcove = np.ones((60, 100), dtype=np.int8)
    alcove[:, :60] = 0
    alcove[20:31, 60:80] = 0
    assert find_passages(planner.grid_map(alcove, resolution=RESOLUTION), RADIUS) == ()
    # Open it onto a second room and it is one.
    alcove[:, 81:] = 0
    alcove[20:31, 80] = 0
    (corridor,) = find_passages(planner.grid_map(alcove, resolution=RESOLUTION), RADIUS)
    assert corridor.width_m == pytest.approx(0.6)
    assert 1.0 <= corridor.length_m <= 1.0 + 2 * 0.2 + 2 * RESOLUTION
    # A pillar in the room: the ring around it is wide, no passage.
    pillar = np.zeros((60, 80), dtype=np.int8)
    pillar[28:32, 38:42] = 1
    assert find_passages(planner.grid_map(pillar, resolution=RESOLUTION), RADIUS) == ()


def test_crossed_passages_in_order() -> None:
    robot_map = doors_map()
    found = find_passages(robot_map, RADIUS, 1.1)
    _, middles = doors_grid()
    row = round(middles[1][0])
    across = [[row, c] for c in range(1, robot_map.shape[1] - 1)]
    assert crossed_passages(found, across, robot_map.shape) == tuple(p.id for p in found)
    assert crossed_passages(found, across[::-1], robot_map.shape) == tuple(
        p.id for p in reversed(found)
    )
    inside = [[row, c] for c in range(2, 40)]
    assert crossed_passages(found, inside, robot_map.shape) == ()
    assert crossed_passages((), across, robot_map.shape) == ()


@pytest.mark.parametrize(
    ("radius", "max_width", "field"),
    [
        (-0.1, None, "robot_radius"),
        (math.nan, None, "robot_radius"),
        (math.inf, None, "robot_radius"),
        (True, None, "robot_radius"),
        ("0.2", None, "robot_radius"),
        (0.2, 0.4, "max_width"),
        (0.2, 0.3, "max_width"),
        (0.2, math.nan, "max_width"),
        (0.2, math.inf, "max_width"),
        (0.2, "1", "max_width"),
        (0.0, 0.0, "max_width"),
    ],
)
def test_bad_input_names_the_field(radius: object, max_width: object, field: str) -> None:
    with pytest.raises(InvalidInput) as info:
        find_passages(doors_map(), radius, max_width)  # type: ignore[arg-type]
    assert info.value.field == field


def reference(
    robot_map: planner.RobotMap, radius: float, max_width: float
) -> list[naive_passages.RefPassage]:
    return naive_passages.passages(robot_map.occupancy, robot_map.resolution, radius, max_width)


def assert_matches(
    robot_map: planner.RobotMap, radius: float, max_width: float, exact: bool
) -> None:
    """Every passage found stands on the reference's medial axis, at the reference's width of
    that neck (to within one cell) when the two readings group the necks alike (``exact``);
    every reference passage's narrowest point lies in a passage found."""
    res = robot_map.resolution
    found = find_passages(robot_map, radius, max_width)
    ref = reference(robot_map, radius, max_width)
    occ = robot_map.occupancy
    blocked = naive_passages.big((occ >= 65) | (occ < 0), res, 0.2)  # specks do not count
    brute = naive_passages.nearest_blocked(blocked, math.ceil(max_width / res / 2) + 3)
    W = robot_map.shape[1]
    for p in found:
        assert p.width_m == pytest.approx(2 * brute[p.row, p.col] * res)
        near = [q for q in ref if any(max(abs(a - p.row), abs(b - p.col)) <= 1 for a, b in q.neck)]
        assert near, f"passage at {(p.row, p.col)} is on no reference neck"
        if exact:
            assert any(abs(p.width_m - q.width_cells * res) <= res + 1e-9 for q in near)
    for q in ref:
        around = {
            (a + dr, b + dc) for a, b in q.narrowest for dr in (-1, 0, 1) for dc in (-1, 0, 1)
        }
        flat = {a * W + b for a, b in around}
        assert any(flat & set(p.cells.tolist()) for p in found), (
            f"reference passage at {q.narrowest[:3]} (width {q.width_cells * res:.3f}) not found"
        )
    if exact:
        assert len(found) == len(ref)


@pytest.mark.parametrize("max_width", [None, 0.9, 1.1, 2.0])
def test_doors_against_the_reference(max_width: float | None) -> None:
    grid, _ = doors_grid((0.35, 0.55, 0.75, 0.95))
    robot_map = planner.grid_map(grid, resolution=RESOLUTION)
    assert_matches(robot_map, RADIUS, max_width or 2 * RADIUS + 0.3, exact=True)


@pytest.mark.parametrize(
    ("name", "radius", "max_width", "exact"),
    [
        ("depot", 0.2, 0.7, True),
        ("depot", 0.35, 1.0, False),  # the two readings split one junction differently
        ("smoothers_world", 0.35, 1.0, True),
        ("smoothers_world", 0.1, 1.0, True),
        ("tb3_sandbox", 0.35, 1.0, True),
        ("tb3_sandbox", 0.1, 1.0, True),
        ("tb3_sandbox", 0.2, 1.2, False),  # among the pillars, necks meet below max_width
    ],
)
def test_ros_maps_against_the_reference(
    ros: Path, name: str, radius: float, max_width: float, exact: bool
) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    assert_matches(robot_map, radius, max_width, exact)


def violet(png: bytes) -> np.ndarray:
    """The pixels of the passages' colour (their labels and dots), as a mask."""
    from PIL import Image

    from planner.render_passages import PASSAGE_COLOUR

    with Image.open(io.BytesIO(png)) as image:
        rgb = np.asarray(image.convert("RGB"))
    mask: np.ndarray = np.all(rgb == PASSAGE_COLOUR, axis=2)
    return mask


def test_renders_draw_the_passages_with_their_width() -> None:
    robot_map = doors_map()
    found = find_passages(robot_map, RADIUS, 1.1)
    analysis = planner.analyse_map(robot_map, planner.resolve_params(robot_radius=RADIUS))
    plain = planner.render_map(analysis, cell=2)
    drawn = planner.render_map(analysis, cell=2, passages=found)
    assert not violet(plain).any()
    mask = violet(drawn)
    for p in found:  # a dot on each narrowest cell, its label beside it
        assert mask[p.row * 2 : p.row * 2 + 2, p.col * 2 : p.col * 2 + 2].all()
        assert mask[p.row * 2 - 8 : p.row * 2 + 8, p.col * 2 + 4 : p.col * 2 + 80].sum() > 20
    rows = [[0] * 9 for _ in range(9)]
    for r in range(9):
        rows[r][4] = 0 if r == 4 else 1
    tiny = planner.grid_map(rows, resolution=0.1)
    result = planner.plan(tiny, [4, 0], [4, 8], robot_radius=0.05)
    (door,) = find_passages(tiny, 0.05, 0.3)
    assert violet(planner.render_plan(result, cell=24, passages=(door,)))[4 * 24 + 12].any()


def test_the_command_line(ros: Path, capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from planner.cli import main

    yaml = str(ros / "depot.yaml")
    args = ["passages", "--map", yaml, "--robot-radius", "0.35", "--max-width", "1.0"]
    assert main([*args, "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)
    found = find_passages(planner.read_ros_map(yaml), 0.35, 1.0)
    assert [(p["x"], p["width_m"]) for p in answer["passages"]] == [
        (round(p.x, 6), round(p.width_m, 6)) for p in found
    ]
    assert (answer["robot_radius"], answer["max_width"]) == (0.35, 1.0)
    png = tmp_path / "passages.png"
    assert main(["passages", "--map", yaml, "--robot-radius", "0.2", "--png", str(png)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("depot.yaml: 2 narrow passage(s) for a robot of radius 0.2 m")
    assert violet(png.read_bytes()).any()
    assert main(["passages", "--map", yaml, "--robot-radius", "0.2", "--max-width", "0.3"]) == 2
    assert "max_width" in capsys.readouterr().err


def test_the_command_line_plan_preview_names_its_passages(
    ros: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from planner.cli import EXAMPLE_MAP, main

    yaml = str(ros / "depot.yaml")
    start, goal = {"x": 24.075, "y": 4.225}, {"x": 22.425, "y": 3.025}
    ends = ["--start", "24.075,4.225", "--goal", "22.425,3.025", "--preset", "shortest"]
    assert main(["plan", "--map", yaml, *ends, "--robot-radius", "0.2", "--json"]) == 0
    preview = json.loads(capsys.readouterr().out)
    robot_map = planner.read_ros_map(yaml)
    result = planner.plan(robot_map, start, goal, preset="shortest", robot_radius=0.2)
    found = find_passages(robot_map, 0.2)
    crossed = list(crossed_passages(found, result.path, robot_map.shape))
    assert preview["passages"] == crossed
    assert len(crossed) >= 1  # it goes through the gap between the shelves
    assert result.analysis.cspace is not None
    x, y, width = planner.path_narrowest(result.analysis.cspace, robot_map.frame, result.path)
    assert preview["narrowest"] == {"x": round(x, 6), "y": round(y, 6), "width_m": round(width, 6)}
    assert width <= min(found[i].width_m for i in crossed)
    grid = ["plan", str(EXAMPLE_MAP), "--start", "7", "2", "--goal", "7", "26", "--json"]
    assert main(grid) == 0
    preview = json.loads(capsys.readouterr().out)
    assert preview["narrowest"] is None
    assert preview["passages"] is None


@given(
    st.lists(st.integers(2, 14), min_size=1, max_size=3),
    st.integers(1, 5),
    st.integers(0, 4),
    st.integers(1, 6),
)
def test_random_doors_against_the_reference(
    gaps: list[int], wall: int, radius_cells: int, slack_cells: int
) -> None:
    """Rooms of 24 cells joined by doors of ``gaps`` cells through walls ``wall`` cells thick,
    a robot of ``radius_cells``, ``max_width`` that many cells over its diameter: the passages
    are the doors of width in (2 R, max_width), each found once at its door, as the reference
    finds them."""
    res = 0.1
    cells = tuple(g * RESOLUTION for g in gaps)  # doors_grid's meters, as cells
    grid, middles = doors_grid(cells, wall=wall * RESOLUTION, room=24 * RESOLUTION)
    robot_map = planner.grid_map(grid, resolution=res)
    radius = radius_cells * res
    max_width = 2 * radius + slack_cells * res
    found = find_passages(robot_map, radius, max_width)
    # A door of g free cells is g + 1 cells wide, center to center, at its middle (g odd) or
    # g cells at the two middle cells (g even).
    widths = [(g + 1 if g % 2 else g) * res for g in gaps]
    expect = [i for i, w in enumerate(widths) if 2 * radius + 1e-9 < w <= max_width + 1e-9]
    assert sorted(door_of(p, middles) for p in found) == expect
    assert_matches(robot_map, radius, max_width, exact=True)


@given(st.integers(0, 2**32 - 1), st.integers(1, 12), st.integers(1, 12), st.floats(0.0, 0.6))
def test_the_medial_axis_against_brute_force(seed: int, H: int, W: int, density: float) -> None:
    rng = np.random.default_rng(seed)
    free = rng.random((H, W)) >= density
    blocked = ~free
    dist = naive.distances(blocked, outside_blocked=True)
    got = medial_axis(free, dist.astype(np.float32))
    np.testing.assert_array_equal(got, naive_passages.medial_axis(free, dist))


def test_the_medial_axis_sorts_its_cells_in_little_memory() -> None:
    """Issue 36 (passages of a 2048 x 2048 map: +372 MB): the sort's keys are built over their
    tiebreak, the cells gathered in place. numpy's allocations at their peak, per free cell:
    25 bytes (the cells, their keys, the sort's order), 49 as numpy expressions."""
    free = np.ones((512, 512), dtype=bool)
    free[200:300, 100:400] = False
    distance = ndimage.distance_transform_edt(np.pad(free, 1))[1:-1, 1:-1].astype(np.float32)
    medial_axis(free, distance)  # compiled first
    tracemalloc.start()
    try:
        medial_axis(free, distance)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 32 * int(free.sum()), peak / free.sum()


@pytest.mark.parametrize("name", ["depot", "tb3_sandbox", "smoothers_world"])
def test_the_medial_axis_is_scikit_images(ros: Path, name: str) -> None:
    skimage = importlib.import_module("skimage.morphology")  # a dev dependency: never skipped

    cs = planner.configuration_space(planner.read_ros_map(ros / f"{name}.yaml"))
    free = cs.blocked == 0
    theirs = skimage.medial_axis(np.pad(free, 1), rng=0)[1:-1, 1:-1]
    np.testing.assert_array_equal(medial_axis(free, cs.distance), theirs)

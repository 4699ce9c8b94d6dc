"""Maps in and out: numpy grids, Moving AI .map text (every letter, CRLF, no final newline),
and .scen files (x is the column)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import planner
from planner.maps.grids import MAP_BLOCKED, MAP_FREE


def test_every_moving_ai_letter() -> None:
    text = "type octile\nheight 1\nwidth 7\nmap\n" + MAP_FREE + MAP_BLOCKED + "\n"
    assert planner.parse_map(text).tolist() == [[0, 0, 0, 1, 1, 1, 1]]


def test_crlf_and_no_final_newline() -> None:
    text = "type octile\r\nheight 2\r\nwidth 3\r\nmap\r\n..@\r\nT.G"
    assert planner.parse_map(text).tolist() == [[0, 0, 1], [1, 0, 0]]


def test_header_in_any_order_and_case() -> None:
    text = "Width 2\nheight 1\ntype octile\nMAP\n.@\n"
    assert planner.parse_map(text).tolist() == [[0, 1]]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("type octile\nheight 1\nwidth 2\n..\n", "no 'map' line"),
        ("type octile\nwidth 2\nmap\n..\n", "no 'height' line"),
        (
            "type octile\nheight x\nwidth 2\nmap\n..\n",
            "'height' must be a positive integer; got 'x'",
        ),
        ("type octile\nheight 2\nwidth 2\nmap\n..\n", "height 2 but only 1 rows follow"),
        ("type octile\nheight 1\nwidth 2\nmap\n..\n..\n", "height 1 but more rows follow"),
        ("type octile\nheight 1\nwidth 3\nmap\n..\n", "width 3 but rows have 2 characters"),
        ("type octile\nheight 2\nwidth 2\nmap\n..\n.\n", r"map row\[1\] has 1 characters"),
        (
            "type octile\nheight 1\nwidth 2\nmap\n.x\n",
            r"map row\[0\] has the character 'x' at column 1",
        ),
        (
            "type octile\nheight 1\nwidth 2\nmap\n.é\n",
            r"map row\[0\] has the character 'é' at column 1",
        ),
    ],
)
def test_bad_map_text_names_the_problem(text: str, message: str) -> None:
    with pytest.raises(planner.InvalidInput, match=message):
        planner.parse_map(text)


def test_rows_round_trip_through_map_text(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    grid = (rng.random((13, 29)) < 0.3).astype(np.uint8)
    path = tmp_path / "m.map"
    path.write_text(planner.format_map(grid))
    np.testing.assert_array_equal(planner.read_map(path), grid)


def test_missing_map_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(planner.InvalidInput, match="does not exist"):
        planner.read_map(tmp_path / "nope.map")


@pytest.mark.parametrize(
    ("grid", "message"),
    [
        ([[0, 1], [0]], "rectangular"),
        ([], "must be a rectangular 2-D array"),
        ([[]], "must not be empty"),
        ([0, 1], "rectangular 2-D"),
        ([[0, 1], [1, 3]], r"found 3 at \[1, 1\]"),
        ([[0, 0.5]], r"found 0.5 at \[0, 1\]"),
        ([["a", "b"]], "must hold numbers"),
    ],
)
def test_bad_grids_name_the_problem(grid: object, message: str) -> None:
    with pytest.raises(planner.InvalidInput, match=message):
        planner.as_grid(grid)


@pytest.mark.parametrize("read", [planner.as_grid, planner.grid_map])
@pytest.mark.parametrize(
    ("grid", "message"),
    [
        ([[0, 0], [0]], "grid[1] has 1 cells; grid[0] has 2"),
        ([[0], [0], [0, 0, 0]], "grid[2] has 3 cells; grid[0] has 1"),
        ([[0, 0], 0], "grid[1] is not a row; grid[0] has 2"),
    ],
)
def test_a_ragged_grid_names_its_first_odd_row(read: Any, grid: object, message: str) -> None:
    with pytest.raises(planner.InvalidInput) as caught:
        read(grid)
    assert str(caught.value) == f"grid must be a rectangular 2-D array: {message}"
    assert caught.value.field == "grid"


def test_grid_accepts_bool_and_int_arrays() -> None:
    assert planner.as_grid(np.array([[True, False]])).dtype == np.uint8
    assert planner.as_grid(np.array([[1, 0]], dtype=np.int64)).tolist() == [[1, 0]]


def test_scen_x_is_the_column(tmp_path: Path) -> None:
    scen = tmp_path / "a.map.scen"
    scen.write_text("version 1\n3\ta.map\t10\t5\t7\t1\t2\t4\t6.5\n")
    (line,) = planner.read_scen(scen)
    assert line.start == (1, 7)
    assert line.goal == (4, 2)
    assert (line.width, line.height, line.optimal, line.bucket) == (10, 5, 6.5, 3)


def test_bad_scen_line_is_named(tmp_path: Path) -> None:
    scen = tmp_path / "b.scen"
    scen.write_text("version 1\n0\ta.map\t10\t5\t7\n")
    with pytest.raises(planner.InvalidInput, match=r"b\.scen line 2 has 5 fields"):
        planner.read_scen(scen)
    scen.write_text("version 1\n0\ta.map\t10\t5\t7\tone\t2\t4\t6.5\n")
    with pytest.raises(planner.InvalidInput, match="line 2 has a field that is not a number"):
        planner.read_scen(scen)


def test_berlin_has_crlf_and_no_final_newline(movingai: Path) -> None:
    raw = (movingai / "Berlin_0_256.map").read_bytes()
    assert b"\r\n" in raw
    assert not raw.endswith(b"\n")
    grid = planner.read_map(movingai / "Berlin_0_256.map")
    assert grid.shape == (256, 256)

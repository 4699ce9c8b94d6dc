"""Occupancy grids in and out: numpy 0/1 arrays, Moving AI ``.map`` text and ``.scen`` files
(whose ``x`` is the column, ``y`` the row: converted here to ``[row, col]``, and nowhere else)."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.errors import InvalidInput, quote

__all__ = [
    "MAP_BLOCKED",
    "MAP_FREE",
    "Scenario",
    "as_cell",
    "as_grid",
    "format_map",
    "parse_map",
    "parse_rows",
    "read_map",
    "read_scen",
]

Grid = npt.NDArray[np.uint8]

#: Moving AI letters: ``.`` ground, ``G`` ground, ``S`` swamp are free; ``@`` and ``O`` out of
#: bounds, ``T`` trees and ``W`` water are blocked (an 8-connected ground robot cannot use them).
MAP_FREE = ".GS"
MAP_BLOCKED = "@OTW"

_LOOKUP = np.full(256, 255, dtype=np.uint8)
for _ch in MAP_FREE:
    _LOOKUP[ord(_ch)] = 0
for _ch in MAP_BLOCKED:
    _LOOKUP[ord(_ch)] = 1


def grid_array(grid: Any, *, name: str = "grid") -> npt.NDArray[Any]:
    """``grid`` as a non-empty rectangular 2-D array of numbers (booleans become ``int8``):
    the checks every grid of cells goes through before its values are checked.

    >>> grid_array([[0, 1], [0]])
    Traceback (most recent call last):
    ...
    planner.errors.InvalidInput: grid must be a rectangular 2-D array: grid[1] has 1 cells; grid[0] has 2
    """  # noqa: E501
    try:
        arr = np.asarray(grid)
    except ValueError:  # ragged nested lists: name the first row that differs
        raise InvalidInput(_ragged(grid, name), field=name) from None
    if arr.dtype == object or arr.ndim != 2:
        msg = f"{name} must be a rectangular 2-D array of numbers; got shape {arr.shape!r}"
        raise InvalidInput(msg, field=name)
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise InvalidInput(f"{name} must not be empty; got shape {arr.shape!r}", field=name)
    if arr.dtype == np.bool_:
        return arr.astype(np.int8)
    if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise InvalidInput(f"{name} must hold numbers; got dtype {arr.dtype}", field=name)
    return arr


def _ragged(grid: Any, name: str) -> str:
    """Why nested lists that numpy refused are not a rectangle: the first row that differs."""
    msg = f"{name} must be a rectangular 2-D array"
    if not isinstance(grid, Sequence) or isinstance(grid, (str, bytes)) or not grid:
        return msg

    def width(row: Any) -> int | None:
        is_row = isinstance(row, Sequence) and not isinstance(row, (str, bytes))
        return len(row) if is_row else None

    def has(i: int, cells: int | None) -> str:
        return f"{name}[{i}] is not a row" if cells is None else f"{name}[{i}] has {cells} cells"

    first = width(grid[0])
    for i in range(1, len(grid)):
        if (cells := width(grid[i])) != first:
            return f"{msg}: {has(i, cells)}; {has(0, first).removesuffix(' cells')}"
    return msg


def as_grid(grid: Any, *, name: str = "grid") -> Grid:
    """Validate an occupancy grid and return it as a C-contiguous ``uint8`` array of 0 and 1.

    >>> as_grid([[0, 1], [0, 0]]).tolist()
    [[0, 1], [0, 0]]
    >>> as_grid([[0, 2]])
    Traceback (most recent call last):
    ...
    planner.errors.InvalidInput: grid must hold only 0 (free) and 1 (blocked); found 2 at [0, 1]
    """
    arr = grid_array(grid, name=name)
    bad = (arr != 0) & (arr != 1)
    if bad.any():
        r, c = (int(v) for v in np.argwhere(bad)[0])
        value = arr[r, c].item()
        msg = f"{name} must hold only 0 (free) and 1 (blocked); found {quote(value)} at [{r}, {c}]"
        raise InvalidInput(msg, field=name)
    return np.ascontiguousarray(arr, dtype=np.uint8)


def as_cell(cell: Any, shape: tuple[int, int], *, name: str) -> tuple[int, int]:
    """Validate a ``[row, col]`` cell inside a map of ``shape``.

    >>> as_cell([1, 2], (3, 3), name="start")
    (1, 2)
    >>> as_cell([3, 0], (3, 3), name="goal")
    Traceback (most recent call last):
    ...
    planner.errors.InvalidInput: goal [3, 0] is outside the 3 x 3 map
    """
    if isinstance(cell, str | bytes) or not isinstance(cell, Sequence | np.ndarray):
        raise InvalidInput(f"{name} must be a [row, col] pair; got {quote(cell)}", field=name)
    values = list(cell)
    if len(values) != 2 or not all(_is_int(v) for v in values):
        raise InvalidInput(
            f"{name} must be a [row, col] pair of integers; got {quote(cell)}", field=name
        )
    r, c = int(values[0]), int(values[1])
    if not (0 <= r < shape[0] and 0 <= c < shape[1]):
        msg = f"{name} [{r}, {c}] is outside the {shape[0]} x {shape[1]} map"
        raise InvalidInput(msg, field=name)
    return r, c


def _is_int(value: Any) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


@njit(cache=True, nogil=True)
def _decode_cells(data: np.ndarray, lookup: np.ndarray) -> tuple[np.ndarray, int]:
    """``lookup[data]`` (bytes to cells) and the index of the first byte it maps to 255 (not a
    map character), or -1: one pass where numpy takes two (the lookup, then the search)."""
    n = data.shape[0]
    out = np.empty(n, dtype=np.uint8)
    bad = 0
    for i in range(n):
        v = lookup[data[i]]
        out[i] = v
        bad |= v == 255
    if bad:
        for i in range(n):
            if out[i] == 255:
                return out, i
    return out, -1


def parse_rows(rows: Sequence[str], *, name: str = "rows") -> Grid:
    """Turn rows of Moving AI characters into a grid, without a Python loop per cell.

    >>> parse_rows(["..@", "T.G"]).tolist()
    [[0, 0, 1], [1, 0, 0]]
    """
    if len(rows) == 0:
        raise InvalidInput(f"{name} must not be empty", field=name)
    width = len(rows[0])
    if width == 0:
        raise InvalidInput(f"{name}[0] is empty; a map needs at least one column", field=name)
    lengths = np.fromiter((len(r) for r in rows), dtype=np.int64, count=len(rows))
    ragged = np.flatnonzero(lengths != width)
    if ragged.size:
        i = int(ragged[0])
        msg = f"{name}[{i}] has {lengths[i]} characters; row 0 has {width}: rows must be equal"
        raise InvalidInput(msg, field=name)
    try:
        data = "".join(rows).encode("ascii")
    except UnicodeEncodeError as exc:
        flat = exc.start
        msg = (
            f"{name}[{flat // width}] has the character {exc.object[flat]!r} at column "
            f"{flat % width}; map characters are {MAP_FREE!r} (free) and {MAP_BLOCKED!r} (blocked)"
        )
        raise InvalidInput(msg, field=name) from None
    cells, bad = _decode_cells(np.frombuffer(data, dtype=np.uint8), _LOOKUP)
    if bad >= 0:
        flat = int(bad)
        msg = (
            f"{name}[{flat // width}] has the character {chr(data[flat])!r} at column "
            f"{flat % width}; map characters are {MAP_FREE!r} (free) and {MAP_BLOCKED!r} (blocked)"
        )
        raise InvalidInput(msg, field=name)
    return cells.reshape(len(rows), width)


def parse_map(text: str) -> Grid:
    """Parse Moving AI ``.map`` text (any line endings, final newline optional).

    >>> parse_map("type octile\\nheight 2\\nwidth 3\\nmap\\n..@\\nT.G").tolist()
    [[0, 0, 1], [1, 0, 0]]
    """
    lines = text.splitlines()
    header: dict[str, str] = {}
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        i += 1
        if not line:
            continue
        if line.lower() == "map":
            break
        key, _, value = line.partition(" ")
        header[key.lower()] = value.strip()
    else:
        raise InvalidInput("map text has no 'map' line before the cells", field="map")
    height = _header_int(header, "height")
    width = _header_int(header, "width")
    rows = lines[i : i + height]
    if len(rows) < height:
        msg = f"map header says height {height} but only {len(rows)} rows follow"
        raise InvalidInput(msg, field="map")
    extra = [line for line in lines[i + height :] if line.strip()]
    if extra:
        msg = f"map header says height {height} but more rows follow: {extra[0][:40]!r}"
        raise InvalidInput(msg, field="map")
    grid = parse_rows(rows, name="map row")
    if grid.shape[1] != width:
        msg = f"map header says width {width} but rows have {grid.shape[1]} characters"
        raise InvalidInput(msg, field="map")
    return grid


def _header_int(header: dict[str, str], key: str) -> int:
    if key not in header:
        raise InvalidInput(f"map header has no '{key}' line", field="map")
    value = header[key]
    if not value.isdigit() or int(value) == 0:
        raise InvalidInput(
            f"map header '{key}' must be a positive integer; got {quote(value)}", field="map"
        )
    return int(value)


def read_map(path: str | os.PathLike[str]) -> Grid:
    """Read a Moving AI ``.map`` file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="ascii")
    except FileNotFoundError:
        raise InvalidInput(f"map file {str(p)!r} does not exist", field="map") from None
    except UnicodeDecodeError as exc:
        raise InvalidInput(f"map file {str(p)!r} is not ASCII text: {exc}", field="map") from None
    return parse_map(text)


def format_map(grid: Any) -> str:
    """Render a grid as Moving AI ``.map`` text (``.`` free, ``@`` blocked)."""
    g = as_grid(grid)
    rows = np.where(g == 0, ord("."), ord("@")).astype(np.uint8)
    body = "\n".join(bytes(row).decode("ascii") for row in rows)
    return f"type octile\nheight {g.shape[0]}\nwidth {g.shape[1]}\nmap\n{body}\n"


@dataclass(frozen=True, slots=True)
class Scenario:
    """One line of a Moving AI ``.scen`` file, with cells in ``[row, col]`` order."""

    bucket: int
    map_name: str
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal: float


def read_scen(path: str | os.PathLike[str]) -> list[Scenario]:
    """Read a Moving AI scenario file (``version 1`` header optional, tab separated)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InvalidInput(f"scenario file {str(p)!r} does not exist", field="scen") from None
    out: list[Scenario] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or line.lower().startswith("version"):
            continue
        parts = line.split("\t") if "\t" in line else line.split()
        if len(parts) != 9:
            msg = f"{p.name} line {number} has {len(parts)} fields, not 9: {line[:60]!r}"
            raise InvalidInput(msg, field="scen")
        try:
            bucket, width, height, sx, sy, gx, gy = (int(v) for v in (parts[0], *parts[2:8]))
            optimal = float(parts[8])
        except ValueError:
            msg = f"{p.name} line {number} has a field that is not a number: {line[:60]!r}"
            raise InvalidInput(msg, field="scen") from None
        if not math.isfinite(optimal):
            raise InvalidInput(f"{p.name} line {number} has optimal {parts[8]!r}", field="scen")
        out.append(Scenario(bucket, parts[1], width, height, (sy, sx), (gy, gx), optimal))
    return out

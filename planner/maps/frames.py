"""Where a map's cells are in meters: the frame (cell centers in meters, and back) and the
checks of its parts (resolution, origin, points)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.errors import InvalidInput, quote
from planner.parsing import number

__all__ = [
    "MAX_EXTENT",
    "MAX_RESOLUTION",
    "MIN_RESOLUTION",
    "MapFrame",
    "framed",
    "origin_of",
    "point_xy",
    "resolution_of",
]

MIN_RESOLUTION = 1e-4
"""Meters per cell at least (0.1 mm): below it, no robot's map."""
MAX_RESOLUTION = 1e3
"""Meters per cell at most (1 km)."""
MAX_EXTENT = 1e7
"""Meters from ``0`` that every corner of a map stays within, on ``x`` and on ``y``: room for
UTM coordinates (northings up to 10,000 km), and where a float64 still tells 2 nm apart, so
that every cell center and every length derived from them (paths, clearances, circles) is
finite and exact to far below a cell."""

Cells = npt.NDArray[np.int64]
Points = npt.NDArray[np.float64]


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
        planner.errors.InvalidInput: goal {'x': 9.0, 'y': 0.0} is outside the map: ...
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


def resolution_of(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise InvalidInput(
            f"{field} must be a number of meters per cell; got {quote(value)}", field=field
        )
    res = float(value)
    if not (math.isfinite(res) and MIN_RESOLUTION <= res <= MAX_RESOLUTION):
        msg = (
            f"{field} must be {MIN_RESOLUTION:g} to {MAX_RESOLUTION:g} meters per cell; "
            f"got {quote(value)}"
        )
        raise InvalidInput(msg, field=field)
    return res


def origin_of(value: Any, field: str) -> tuple[float, float, float]:
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence | np.ndarray):
        raise InvalidInput(f"{field} must be [x, y, yaw]; got {quote(value)}", field=field)
    items = list(value)
    if len(items) != 3:
        raise InvalidInput(f"{field} must be [x, y, yaw]; got {quote(value)}", field=field)
    x, y, yaw = (number(v, field) for v in items)
    return (x + 0.0, y + 0.0, yaw + 0.0)  # + 0.0: no negative zero


def framed(
    shape: tuple[int, int],
    resolution: float,
    origin: tuple[float, float, float],
    *,
    fields: tuple[str, str] = ("resolution", "origin"),
) -> MapFrame:
    """The frame of a map of ``shape`` cells, refused (naming ``fields``: the resolution's,
    the origin's) unless every corner of the map lies within :data:`MAX_EXTENT` meters of 0 on
    both axes, whatever its yaw. ``resolution`` and ``origin`` are checked already."""
    H, W = shape
    span = math.hypot(W, H) * resolution  # the farthest corner from the origin, at any yaw
    if span > MAX_EXTENT:
        msg = (
            f"{fields[0]} {resolution:g} m a cell makes the {H} x {W} map {span:.3g} m across; "
            f"every corner must be within {MAX_EXTENT:,.0f} m of 0"
        )
        raise InvalidInput(msg, field=fields[0])
    ox, oy, _ = origin
    if max(abs(ox), abs(oy)) + span > MAX_EXTENT:
        msg = (
            f"{fields[1]} {quote(list(origin))} puts the map's corners up to "
            f"{max(abs(ox), abs(oy)) + span:.3g} m from 0; every corner must be within "
            f"{MAX_EXTENT:,.0f} m of 0 (x and y)"
        )
        raise InvalidInput(msg, field=fields[1])
    return MapFrame(shape, resolution, origin)

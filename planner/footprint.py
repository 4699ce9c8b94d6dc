"""A robot's footprint: a polygon in its own frame (meters, x forward), validated, and its
cells per heading bin, the table the collision kernels read (Nav2's Smac planners check a
footprint the same way: one precomputed set of cells per heading bin).

>>> fp = footprint_of([[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]])
>>> round(fp.inscribed_radius, 3), round(fp.circumscribed_radius, 3)
(0.2, 0.361)
>>> footprint_of([[0, 0], [1, 1], [1, 0], [0, 1]])  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
planner.errors.InvalidInput: footprint crosses itself (a polygon's edges may only meet ...
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from shapely.geometry import Polygon

from planner.errors import InvalidInput, quote

__all__ = [
    "HEADING_BINS",
    "MAX_VERTICES",
    "Footprint",
    "FootprintCells",
    "footprint_cells",
    "footprint_of",
]

MAX_VERTICES = 32
"""Vertices a footprint has at most."""

HEADING_BINS = 72
"""Heading bins of the collision table and of the hybrid search (5 degrees each)."""

MIN_AREA = 1e-4
"""Square meters a footprint covers at least (a smaller one is degenerate: a line or a point)."""

_SWEEP_STEP = math.radians(1.0)
"""Headings a bin's swept footprint is drawn at, this far apart (the gap is added as a margin)."""


@dataclass(frozen=True, slots=True)
class Footprint:
    """A simple polygon in the robot's frame, meters, x forward, counter-clockwise; the robot's
    reference point (the pose's x, y) is the origin, which the polygon contains."""

    vertices: tuple[tuple[float, float], ...]

    @property
    def polygon(self) -> Polygon:
        return Polygon(self.vertices)

    @property
    def inscribed_radius(self) -> float:
        """Meters from the origin to the nearest edge: the largest disc about the reference
        point inside the footprint (every pose of the footprint holds it)."""
        return float(self.polygon.exterior.distance(shapely.Point(0.0, 0.0)))

    @property
    def circumscribed_radius(self) -> float:
        """Meters from the origin to the farthest vertex: the enclosing circle about the
        reference point (what a fleet plans the robot as)."""
        return max(math.hypot(x, y) for x, y in self.vertices)

    def as_list(self) -> list[list[float]]:
        return [[x, y] for x, y in self.vertices]


def footprint_of(value: Any, field: str = "footprint") -> Footprint:
    """A footprint from a list of 3 to 32 ``[x, y]`` vertices in meters: a simple polygon (its
    edges meet only at its vertices) of some area that holds the robot's reference point
    (the origin). Anything else is refused naming ``field``."""
    if isinstance(value, Footprint):
        return value
    if not isinstance(value, list | tuple) or not 3 <= len(value) <= MAX_VERTICES:
        size = f"{len(value)} vertices" if isinstance(value, list | tuple) else quote(value)
        msg = f"{field} must be a list of 3 to {MAX_VERTICES} [x, y] vertices; got {size}"
        raise InvalidInput(msg, field=field)
    points: list[tuple[float, float]] = []
    for i, vertex in enumerate(value):
        ok = isinstance(vertex, list | tuple) and len(vertex) == 2
        ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in vertex)
        if not ok or not all(math.isfinite(v) for v in vertex):
            msg = f"{field}[{i}] must be [x, y], two finite numbers of meters; got {quote(vertex)}"
            raise InvalidInput(msg, field=f"{field}[{i}]")
        points.append((float(vertex[0]), float(vertex[1])))
    spread = np.linalg.svd(np.array(points) - np.mean(points, axis=0), compute_uv=False)
    if spread[-1] < 1e-6:
        msg = f"{field} is degenerate: its vertices lie on a line or at a point; got {quote(value)}"
        raise InvalidInput(msg, field=field)
    ring = shapely.LinearRing(points)
    if not ring.is_simple:
        msg = (
            f"{field} crosses itself (a polygon's edges may only meet at its vertices); "
            f"got {quote(value)}"
        )
        raise InvalidInput(msg, field=field)
    polygon = Polygon(points)
    if polygon.area < MIN_AREA:
        msg = (
            f"{field} is degenerate: it covers {polygon.area:.3g} square meters (at least "
            f"{MIN_AREA:g}: not a line or a point); got {quote(value)}"
        )
        raise InvalidInput(msg, field=field)
    if not polygon.contains(shapely.Point(0.0, 0.0)):
        msg = (
            f"{field} must hold the robot's reference point [0, 0] strictly inside (its "
            f"vertices are in the robot's frame); got {quote(value)}"
        )
        raise InvalidInput(msg, field=field)
    if not ring.is_ccw:
        points.reverse()
    return Footprint(tuple(points))


@dataclass(frozen=True, eq=False)
class FootprintCells:
    """A footprint's cells per heading bin on a map of ``resolution`` meters a cell.

    ``offsets[starts[b]:starts[b + 1]]`` are the ``[drow, dcol]`` cells whose center may lie in
    the footprint of a robot whose reference point is anywhere in the cell ``[0, 0]`` (grown by
    ``pad`` cells) and whose heading is within bin ``b`` (grown by ``pad_angle`` radians): a
    pose whose cell and bin find none of them blocked is free, whatever its exact place in
    the cell. Bin ``b`` holds headings ``b * 2 pi / bins`` +- half a bin, in the grid's frame
    (x along the columns, y up the rows). ``edge``/``edge_starts`` list the cells the
    footprint's outline crosses at each bin's center heading (its clearance is read there);
    ``reach`` bounds, in cells, how far any offset lies from ``[0, 0]``.
    """

    footprint: Footprint
    resolution: float
    bins: int
    pad: float
    pad_angle: float
    offsets: npt.NDArray[np.int32]
    starts: npt.NDArray[np.int64]
    edge: npt.NDArray[np.int32]
    edge_starts: npt.NDArray[np.int64]
    reach: float


def footprint_cells(
    footprint: Footprint,
    resolution: float,
    *,
    bins: int = HEADING_BINS,
    pad: float = 0.25,
    pad_angle: float | None = None,
) -> FootprintCells:
    """The collision table of ``footprint`` on cells of ``resolution`` meters (cached: a map's
    plans share it). ``pad`` (cells) and ``pad_angle`` (radians, default a quarter bin) grow
    each bin's area so that a motion checked at poses that far apart is covered between them."""
    angle = math.pi / (2 * bins) if pad_angle is None else pad_angle
    return _cells(footprint, float(resolution), int(bins), float(pad), float(angle))


@lru_cache(maxsize=64)
def _cells(
    footprint: Footprint, resolution: float, bins: int, pad: float, pad_angle: float
) -> FootprintCells:
    poly = shapely.affinity.scale(footprint.polygon, 1 / resolution, 1 / resolution, origin=(0, 0))
    far = footprint.circumscribed_radius / resolution
    half_bin = math.pi / bins
    # A point at radius r sweeps r * step between two drawn headings: half of it off both.
    half = 0.5 + pad + far * _SWEEP_STEP / 2 + 1e-6
    reach = math.ceil(far + half * math.sqrt(2)) + 1
    grid = np.arange(-reach, reach + 1)
    dr, dc = (a.ravel() for a in np.meshgrid(grid, grid, indexing="ij"))
    # A cell's center q may be in the footprint of a reference point within ``half`` of the
    # cell's center (Chebyshev) when the square of that half about q meets the footprint.
    boxes = shapely.box(dc - half, -dr - half, dc + half, -dr + half)
    offsets: list[npt.NDArray[np.int32]] = []
    edges: list[npt.NDArray[np.int32]] = []
    for b in range(bins):
        center = b * 2 * math.pi / bins
        low, high = center - half_bin - pad_angle, center + half_bin + pad_angle
        inside = np.zeros(len(dr), dtype=bool)
        for a in np.linspace(low, high, max(2, math.ceil((high - low) / _SWEEP_STEP) + 1)):
            turned = shapely.affinity.rotate(poly, a, origin=(0, 0), use_radians=True)
            shapely.prepare(turned)
            inside |= shapely.intersects(turned, boxes)
        offsets.append(np.stack([dr[inside], dc[inside]], axis=1).astype(np.int32))
        edges.append(_outline_cells(shapely.affinity.rotate(poly, center, (0, 0), True)))
    starts = np.zeros(bins + 1, dtype=np.int64)
    starts[1:] = np.cumsum([len(o) for o in offsets])
    edge_starts = np.zeros(bins + 1, dtype=np.int64)
    edge_starts[1:] = np.cumsum([len(e) for e in edges])
    table = np.ascontiguousarray(np.concatenate(offsets))
    outline = np.ascontiguousarray(np.concatenate(edges))
    for arr in (table, starts, outline, edge_starts):
        arr.flags.writeable = False
    reach_cells = float(np.hypot(table[:, 0], table[:, 1]).max()) if len(table) else 0.0
    return FootprintCells(
        footprint, resolution, bins, pad, pad_angle, table, starts, outline, edge_starts,
        reach_cells,
    )  # fmt: skip


def _outline_cells(polygon: Polygon) -> npt.NDArray[np.int32]:
    """The ``[drow, dcol]`` cells holding points of ``polygon``'s outline (in cells), sampled
    every half cell."""
    ring = polygon.exterior
    count = max(8, math.ceil(ring.length * 2))
    points = shapely.get_coordinates(
        shapely.line_interpolate_point(ring, np.linspace(0, ring.length, count, endpoint=False))
    )
    cells = np.unique(np.stack([-np.round(points[:, 1]), np.round(points[:, 0])], axis=1), axis=0)
    out: npt.NDArray[np.int32] = cells.astype(np.int32)
    return out

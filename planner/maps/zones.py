"""Zones on a map (docs/zones.md): keepout polygons and masks, which block cells, and speed
zones, which cap the speed of the poses inside them; what a zoned map keeps of them.

>>> zones = Zones(
...     base_map_id="ab" * 32,
...     speed=(SpeedZone(((0.0, 0.0), (1.0, 0.0), (1.0, 1.0)), 0.3),),
... )
>>> speed_limits(zones, [[0.7, 0.2], [0.2, 0.7]]).tolist()
[0.3, inf]
>>> Zones.from_dict(zones.as_dict()) == zones
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.errors import InvalidInput, quote
from planner.maps.frames import MapFrame
from planner.maps.polygons import Polygon, check_polygon, polygon_cells
from planner.maps.speed_index import SpeedIndex, speed_index

__all__ = [
    "MAX_SPEED",
    "MAX_ZONES",
    "MAX_ZONE_POINTS",
    "KeepoutMask",
    "SpeedZone",
    "Zones",
    "check_zones",
    "keepout_cells",
    "speed_limits",
]

MAX_ZONES = 256
"""Zones a map may carry at most: keepout polygons, speed zones and keepout masks together, its
base map's and the new ones (zoning a zoned map adds to its zones)."""
MAX_ZONE_POINTS = 10_000
"""Points a map's polygons may have in all, its base map's and the new ones: the work of
checking, storing, answering and drawing them."""
POINT_BYTES = 112
"""What a polygon's point holds in memory: a tuple of two floats, and its place in the polygon."""
MAX_SPEED = 100.0
"""A speed zone's ``max_speed`` at most, m/s."""


@dataclass(frozen=True, slots=True)
class SpeedZone:
    """A polygon where the robot drives at ``max_speed`` m/s at most."""

    polygon: Polygon
    max_speed: float


@dataclass(frozen=True, slots=True)
class KeepoutMask:
    """A keepout filter mask applied: how many of the map's cells it marks (``cells``) and the
    SHA-256 of its keepout bitmap (one byte a cell, row 0 first)."""

    cells: int
    sha256: str


@dataclass(frozen=True, slots=True)
class Zones:
    """The zones of a zoned map: the map they were applied to (``base_map_id``), and every
    keepout polygon, keepout mask and speed zone it has, its base's own zones first."""

    base_map_id: str
    keepout: tuple[Polygon, ...] = ()
    speed: tuple[SpeedZone, ...] = ()
    keepout_masks: tuple[KeepoutMask, ...] = ()
    _speed_index: SpeedIndex | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def count(self) -> int:
        """The zones: keepout polygons, speed zones and keepout masks."""
        return len(self.keepout) + len(self.speed) + len(self.keepout_masks)

    @property
    def points(self) -> int:
        """The points of every polygon, keepout and speed."""
        return sum(map(len, self.keepout)) + sum(len(z.polygon) for z in self.speed)

    @property
    def nbytes(self) -> int:
        """About what the zones hold in memory (a store charges it beside the cells)."""
        return POINT_BYTES * self.points + 2 * POINT_BYTES * self.count

    def speed_index(self) -> SpeedIndex:
        """Its speed zones' :class:`~planner.maps.speed_index.SpeedIndex`, built on first use
        and kept with the zones (:func:`speed_limits` looks caps up through it)."""
        index = self._speed_index
        if index is None:
            index = speed_index([z.polygon for z in self.speed], [z.max_speed for z in self.speed])
            object.__setattr__(self, "_speed_index", index)
        return index

    def as_dict(self) -> dict[str, Any]:
        """The zones as JSON-ready data (``GET /maps/{id}``'s ``zones``)."""
        return {
            "base_map_id": self.base_map_id,
            "keepout": [_points(p) for p in self.keepout],
            "speed": [
                {"polygon": _points(z.polygon), "max_speed": z.max_speed} for z in self.speed
            ],
            "keepout_masks": [{"cells": m.cells, "sha256": m.sha256} for m in self.keepout_masks],
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Zones:
        """:meth:`as_dict`'s zones back (data this module wrote: not checked again)."""

        def polygon(points: Sequence[Mapping[str, float]]) -> Polygon:
            return tuple((float(p["x"]), float(p["y"])) for p in points)

        return cls(
            base_map_id=str(data["base_map_id"]),
            keepout=tuple(polygon(p) for p in data["keepout"]),
            speed=tuple(
                SpeedZone(polygon(z["polygon"]), float(z["max_speed"])) for z in data["speed"]
            ),
            keepout_masks=tuple(
                KeepoutMask(int(m["cells"]), str(m["sha256"])) for m in data["keepout_masks"]
            ),
        )


def _points(polygon: Polygon) -> list[dict[str, float]]:
    return [{"x": x, "y": y} for x, y in polygon]


def check_zones(
    keepout: Any = (), speed: Any = (), *, carried: Zones | None = None, masks: int = 0
) -> tuple[tuple[Polygon, ...], tuple[SpeedZone, ...]]:
    """Keepout polygons and speed zones (``{"polygon", "max_speed"}``) as given in a request,
    checked (:func:`~planner.maps.polygons.check_polygon`; ``max_speed`` in m/s, positive and
    finite), every error naming its field. With the zones the map already ``carried`` and the
    ``masks`` the request adds, the map's zones and points stay within :data:`MAX_ZONES` and
    :data:`MAX_ZONE_POINTS`: the error names the first field beyond."""
    for name, value in (("keepout", keepout), ("speed", speed)):
        if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence):
            raise InvalidInput(f"{name} must be a list; got {quote(value)}", field=name)
    _check_room(keepout, speed, carried, masks)
    polygons = tuple(check_polygon(p, field=f"keepout[{i}]") for i, p in enumerate(keepout))
    zones = []
    for i, zone in enumerate(speed):
        field = f"speed[{i}]"
        if not isinstance(zone, Mapping):
            raise InvalidInput(
                f"{field} must be {{polygon, max_speed}}; got {quote(zone)}", field=field
            )
        unknown = sorted(str(k) for k in zone if k not in ("polygon", "max_speed"))
        if unknown:
            msg = f"{field} has no field {quote(unknown[0])} (it takes polygon, max_speed)"
            raise InvalidInput(msg, field=f"{field}.{unknown[0][:100]}")
        for key in ("polygon", "max_speed"):
            if key not in zone:
                raise InvalidInput(f"{field} has no '{key}'", field=f"{field}.{key}")
        speed_ = zone["max_speed"]
        if (
            isinstance(speed_, bool)
            or not isinstance(speed_, int | float)
            or not (math.isfinite(speed_) and 0 < speed_ <= MAX_SPEED)
        ):
            msg = f"{field}.max_speed must be in (0, {MAX_SPEED:g}] m/s; got {quote(speed_)}"
            raise InvalidInput(msg, field=f"{field}.max_speed")
        polygon = check_polygon(zone["polygon"], field=f"{field}.polygon")
        zones.append(SpeedZone(polygon, float(speed_)))
    return polygons, tuple(zones)


def _check_room(
    keepout: Sequence[Any], speed: Sequence[Any], carried: Zones | None, masks: int
) -> None:
    """The map's zones and points, ``carried`` and new, within the limits (checked before the
    polygons: on the counts as given)."""
    has = 0 if carried is None else carried.count
    fields = [f"keepout[{i}]" for i in range(len(keepout))]
    fields += [f"speed[{i}]" for i in range(len(speed))] + ["image"] * masks
    if has + len(fields) > MAX_ZONES:
        beyond = fields[max(0, MAX_ZONES - has)]
        msg = (
            f"a map carries at most {MAX_ZONES} zones (keepout, speed and masks together, its "
            f"base map's with the new); it has {has} and the request adds {len(fields)}: "
            f"{beyond} is beyond"
        )
        raise InvalidInput(msg, field=beyond)
    points = [_length(p) for p in keepout]
    points += [_length(z.get("polygon")) if isinstance(z, Mapping) else 0 for z in speed]
    total = has_points = 0 if carried is None else carried.points
    for i, count in enumerate(points):
        total += count
        if total > MAX_ZONE_POINTS:
            beyond = fields[i] if i < len(keepout) else f"{fields[i]}.polygon"
            msg = (
                f"a map's polygons have at most {MAX_ZONE_POINTS} points in all (its base map's "
                f"with the new); it has {has_points} and the request adds {sum(points)}: "
                f"{beyond} is beyond"
            )
            raise InvalidInput(msg, field=beyond)


def _length(points: Any) -> int:
    return len(points) if isinstance(points, Sequence) and not isinstance(points, str) else 0


def keepout_cells(frame: MapFrame, polygons: Sequence[Polygon]) -> npt.NDArray[np.bool_]:
    """``(H, W)`` bool: the cells whose centers a keepout polygon holds. A polygon that holds
    no cell's center (off the map, or smaller than a cell between centers) is refused: it would
    keep nothing out."""
    out = np.zeros(frame.shape, dtype=np.bool_)
    for i, polygon in enumerate(polygons):
        cells = polygon_cells(frame, polygon)
        if not cells.any():
            msg = (
                f"keepout[{i}] holds no cell's center of the map: {frame.describe()}; "
                f"its first point is {quote(list(polygon[0]))}"
            )
            raise InvalidInput(msg, field=f"keepout[{i}]")
        out |= cells
    return out


def speed_limits(zones: Zones | None, points: Any) -> npt.NDArray[np.float64]:
    """The speed cap (m/s) at each of an ``(n, 2)`` array of ``[x, y]`` points: the least
    ``max_speed`` of the speed zones holding it, ``inf`` outside every zone: looked up through
    the zones' :meth:`Zones.speed_index` (a grid built once), not a loop over the polygons."""
    if zones is None:
        return np.full(len(np.asarray(points, dtype=np.float64).reshape(-1, 2)), np.inf)
    return zones.speed_index().caps(points)

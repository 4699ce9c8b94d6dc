"""Speed caps looked up through a grid built with the speed zones (docs/zones.md): a point is
tested against the few zones whose edges pass through its bucket, not against every polygon.

Each square bucket of a grid over the zones keeps the least ``max_speed`` of the zones that hold
it whole, and lists the zones whose edges pass through it. A bucket no edge of a zone touches is
wholly inside that zone or wholly outside it, so the cap at a point is its bucket's, lowered by
the crossing zones that hold the point (the crossing test of
:func:`~planner.maps.polygons.points_in_polygon`): the caps are the polygon loop's, exactly.

>>> index = speed_index([((0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0))], [0.3])
>>> index.caps([[2.0, 2.0], [3.99, 0.01], [4.5, 2.0], [1e6, 1e6]]).tolist()
[0.3, 0.3, inf, inf]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.maps.frames import MapFrame
from planner.maps.polygons import Polygon, points_in_polygon, polygon_cells

__all__ = ["BUCKETS", "SpeedIndex", "speed_index"]

BUCKETS = 128
"""Buckets along the longer side of the zones' bounding box (one more all around)."""

# The 3 x 3 neighbourhood: a bucket an edge's samples fall in, and those around it.
_AROUND = np.array([(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1)], dtype=np.int64)


@dataclass(frozen=True, slots=True)
class SpeedIndex:
    """The speed zones (``polygons`` and their ``limits``, m/s) bucketed on the grid ``frame``
    (square buckets, yaw 0): ``whole`` (the least cap of the zones holding each bucket whole,
    ``inf`` elsewhere), and the zones whose edges pass through bucket ``k`` (flat):
    ``crossing[starts[k]:starts[k + 1]]``."""

    frame: MapFrame
    whole: npt.NDArray[np.float64]
    starts: npt.NDArray[np.int64]
    crossing: npt.NDArray[np.int32]
    polygons: tuple[Polygon, ...]
    limits: tuple[float, ...]

    @property
    def nbytes(self) -> int:
        return int(self.whole.nbytes + self.starts.nbytes + self.crossing.nbytes)

    def caps(self, points: Any) -> npt.NDArray[np.float64]:
        """The speed cap (m/s) at each of an ``(n, 2)`` array of ``[x, y]`` points: the least
        ``max_speed`` of the zones holding it, ``inf`` outside every zone."""
        xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        out = np.full(len(xy), np.inf)
        if not self.polygons or not len(xy):
            return out
        rows, cols = self.frame.shape
        x0, y0, _ = self.frame.origin
        u = np.floor((xy[:, 0] - x0) / self.frame.resolution)
        v = np.floor((xy[:, 1] - y0) / self.frame.resolution)
        on = (u >= 0) & (u < cols) & (v >= 0) & (v < rows)  # outside the grid: in no zone
        at = np.flatnonzero(on)
        flat = (rows - 1 - v[at].astype(np.int64)) * cols + u[at].astype(np.int64)
        out[at] = self.whole.ravel()[flat]
        first, counts = self.starts[flat], self.starts[flat + 1] - self.starts[flat]
        if not counts.any():
            return out
        point = np.repeat(at, counts)
        offset = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
        zone = self.crossing[np.repeat(first, counts) + offset]
        for z in np.unique(zone).tolist():
            mine = point[zone == z]
            inside = mine[points_in_polygon(xy[mine], self.polygons[z])]
            out[inside] = np.minimum(out[inside], self.limits[z])
        return out


def speed_index(polygons: Sequence[Polygon], limits: Sequence[float]) -> SpeedIndex:
    """The :class:`SpeedIndex` of speed zones: ``polygons`` (checked: simple, finite) and their
    ``limits`` (m/s)."""
    if len(polygons) != len(limits):
        msg = f"{len(polygons)} polygons given with {len(limits)} limits"
        raise ValueError(msg)
    if not polygons:
        none = np.zeros(0, np.int32)
        inf = np.full((1, 1), np.inf)
        return SpeedIndex(MapFrame((1, 1)), inf, np.zeros(2, np.int64), none, (), ())
    points = np.concatenate([np.asarray(p, dtype=np.float64) for p in polygons])
    lo, hi = points.min(axis=0), points.max(axis=0)
    # Not so fine that a bucket's side vanishes against the coordinates' magnitude.
    size = max(float((hi - lo).max()) / BUCKETS, 1e-9 * max(1.0, float(np.abs(points).max())))
    cols, rows = (np.ceil((hi - lo) / size).astype(np.int64) + 3).tolist()
    frame = MapFrame((rows, cols), size, (float(lo[0]) - size, float(lo[1]) - size, 0.0))
    whole = np.full(rows * cols, np.inf)
    buckets, owners = [], []
    for i, (polygon, limit) in enumerate(zip(polygons, limits, strict=True)):
        crossed = _crossed(frame, polygon)
        inside = polygon_cells(frame, polygon).ravel()
        inside[crossed] = False
        whole[inside] = np.minimum(whole[inside], limit)
        buckets.append(crossed)
        owners.append(np.full(len(crossed), i, dtype=np.int32))
    bucket, owner = np.concatenate(buckets), np.concatenate(owners)
    order = np.argsort(bucket, kind="stable")
    starts = np.zeros(rows * cols + 1, dtype=np.int64)
    np.cumsum(np.bincount(bucket, minlength=rows * cols), out=starts[1:])
    return SpeedIndex(
        frame, whole.reshape(rows, cols), starts, owner[order], tuple(polygons), tuple(limits)
    )


def _crossed(frame: MapFrame, polygon: Polygon) -> npt.NDArray[np.int64]:
    """The buckets (flat, sorted) the polygon's edges may pass through: samples along each
    edge at most half a bucket apart, and the buckets around theirs (so that every bucket an
    edge touches is among them, whatever the rounding)."""
    a = np.asarray(polygon, dtype=np.float64)
    b = np.roll(a, -1, axis=0)
    lengths = np.hypot(*(b - a).T)
    n = np.ceil(lengths / (frame.resolution / 2)).astype(np.int64) + 1
    edge = np.repeat(np.arange(len(a)), n)
    t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n - 1, n)
    samples = a[edge] + t[:, None] * (b - a)[edge]
    near = np.unique(frame.cells(samples), axis=0)
    rows, cols = frame.shape
    around = (near[:, None, :] + _AROUND[None, :, :]).reshape(-1, 2)
    around[:, 0] = np.clip(around[:, 0], 0, rows - 1)
    around[:, 1] = np.clip(around[:, 1], 0, cols - 1)
    out: npt.NDArray[np.int64] = np.unique(around[:, 0] * cols + around[:, 1])
    return out

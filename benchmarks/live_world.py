"""A simulated laser for the live-layer benchmark, figure and tests: scans ray-cast from a
map's blocked cells plus moving boxes, as rosbridge's ``sensor_msgs/LaserScan`` JSON.

Rays are marched in steps of a quarter cell (numpy, all rays at once): a return is the first
sample inside a blocked cell or a box; a ray leaving the map, or reaching ``range_max``, has
none (``null``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class Box:
    """An axis-aligned box in meters, the map frame: ``(x0, y0)`` to ``(x1, y1)``."""

    x0: float
    y0: float
    x1: float
    y1: float

    def holds(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        return (x >= self.x0) & (x <= self.x1) & (y >= self.y0) & (y <= self.y1)

    def moved(self, dx: float, dy: float) -> Box:
        return Box(self.x0 + dx, self.y0 + dy, self.x1 + dx, self.y1 + dy)


def cast(
    blocked: npt.NDArray[np.bool_],
    frame: Any,
    pose: tuple[float, float, float],
    boxes: Sequence[Box] = (),
    *,
    rays: int = 1080,
    range_min: float = 0.05,
    range_max: float = 12.0,
    fov: float = 2 * math.pi,
) -> dict[str, Any]:
    """A scan of ``rays`` rays over ``fov`` radians centred on the pose's heading, taken at
    ``pose`` (x, y, yaw) on a map of ``frame`` (a ``planner.MapFrame``) whose ``blocked``
    cells and ``boxes`` return the rays."""
    x, y, yaw = pose
    increment = fov / rays if fov >= 2 * math.pi else fov / max(rays - 1, 1)
    angle_min = -fov / 2
    angles = yaw + angle_min + increment * np.arange(rays)
    step = frame.resolution / 4
    # Samples between quarter-cell marks: a return lies inside what it hit, never on an edge.
    t = np.arange(step / 2, range_max, step)
    px = x + np.cos(angles)[:, None] * t[None, :]
    py = y + np.sin(angles)[:, None] * t[None, :]
    cells = frame.cells(np.stack([px.ravel(), py.ravel()], axis=1))
    H, W = blocked.shape
    r, c = cells[:, 0], cells[:, 1]
    inside = (r >= 0) & (r < H) & (c >= 0) & (c < W)
    hit = np.zeros(len(cells), dtype=bool)
    hit[inside] = blocked[r[inside], c[inside]]
    hit = hit.reshape(px.shape)
    for box in boxes:
        hit |= box.holds(px, py)
    out = (~inside).reshape(px.shape)
    ranges: list[float | None] = []
    for k in range(rays):
        first_hit = np.argmax(hit[k]) if hit[k].any() else len(t)
        first_out = np.argmax(out[k]) if out[k].any() else len(t)
        if first_hit < first_out and first_hit < len(t):
            ranges.append(float(t[first_hit]))
        else:
            ranges.append(None)
    return {
        "angle_min": angle_min,
        "angle_increment": increment,
        "range_min": range_min,
        "range_max": range_max,
        "ranges": ranges,
    }


def hit_points(scan: dict[str, Any], pose: tuple[float, float, float]) -> npt.NDArray[np.float64]:
    """The returns of ``scan`` at ``pose`` as ``(n, 2)`` points in meters."""
    x, y, yaw = pose
    out = []
    for i, rng in enumerate(scan["ranges"]):
        if rng is not None and scan["range_min"] <= rng < scan["range_max"]:
            a = yaw + scan["angle_min"] + i * scan["angle_increment"]
            out.append((x + rng * math.cos(a), y + rng * math.sin(a)))
    return np.array(out, dtype=np.float64).reshape(-1, 2)

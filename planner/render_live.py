"""Pictures of the live layer (docs/live.md): a map with the cells the robots' scans marked,
and optionally a scan's rays and robots' routes over it."""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

from planner.errors import InvalidInput, quote
from planner.maps.robot_maps import RobotMap
from planner.render_legend import COLOURS

__all__ = ["LIVE_COLOUR", "draw_live", "render_live"]

LIVE_COLOUR = (220, 30, 30)
"""A live mark: red, as Nav2's tools draw an obstacle layer's marks."""


def draw_live(
    robot_map: RobotMap,
    marks: Any,
    *,
    cell: int = 2,
    rays: Any = None,
    routes: Sequence[tuple[Any, tuple[int, int, int]]] = (),
) -> Image.Image:
    """The map (blocked black, unknown grey-blue, free white) with the ``marks`` (``(n, 2)``
    cells) red over everything, ``cell`` pixels a cell; ``rays`` (``(origin (x, y), ends
    (m, 2))`` in meters) as thin amber lines, and ``routes`` (poses or points ``(k, >=2)`` in
    meters, each with a colour) as lines."""
    if isinstance(cell, bool) or not isinstance(cell, int) or not 1 <= cell <= 64:
        raise InvalidInput(f"cell must be an integer in [1, 64]; got {quote(cell)}", field="cell")
    H, W = robot_map.shape
    rgb = np.empty((H, W, 3), dtype=np.uint8)
    rgb[:] = COLOURS["free"]
    rgb[robot_map.occupancy < 0] = COLOURS["unknown"]
    rgb[robot_map.blocked()] = COLOURS["obstacle"]
    cells = np.asarray(marks, dtype=np.int64).reshape(-1, 2)
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < H) & (cells[:, 1] >= 0) & (cells[:, 1] < W)
    cells = cells[inside]
    image = Image.fromarray(np.repeat(np.repeat(rgb, cell, axis=0), cell, axis=1), "RGB")
    pen = ImageDraw.Draw(image)
    frame = robot_map.frame

    def pixels(points: Any) -> list[tuple[float, float]]:
        xy = np.asarray(points, dtype=np.float64).reshape(-1, np.shape(points)[-1])[:, :2]
        ox, oy, yaw = frame.origin
        dx, dy = xy[:, 0] - ox, xy[:, 1] - oy
        u = (np.cos(yaw) * dx + np.sin(yaw) * dy) / frame.resolution
        v = (-np.sin(yaw) * dx + np.cos(yaw) * dy) / frame.resolution
        return list(zip((u * cell).tolist(), ((H - v) * cell).tolist(), strict=True))

    if rays is not None:
        origin, ends = rays
        (o,) = pixels([origin])
        for end in pixels(ends):
            pen.line([o, end], fill=(250, 215, 140), width=1)
    for route, colour in routes:
        points = pixels(route)
        if len(points) > 1:
            pen.line(points, fill=colour, width=max(2, cell // 2 + 1), joint="curve")
    for r, c in cells.tolist():  # over the routes: what the robots go round
        pen.rectangle(
            (c * cell, r * cell, (c + 1) * cell - 1, (r + 1) * cell - 1), fill=LIVE_COLOUR
        )
    return image


def render_live(robot_map: RobotMap, marks: Any, *, cell: int = 2) -> bytes:
    """PNG bytes of :func:`draw_live` (the ``live.png`` endpoint).

    >>> from planner import grid_map
    >>> render_live(grid_map([[0, 1]]), [[0, 0]], cell=2)[1:4]
    b'PNG'
    """
    out = io.BytesIO()
    draw_live(robot_map, marks, cell=cell).save(out, format="PNG")
    return out.getvalue()

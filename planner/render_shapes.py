"""Footprints in pictures: the robot's outline at poses along its path, forward and reverse in
two colours (docs/shapes.md)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

from planner.analysis.analyse import Analysis
from planner.errors import InvalidInput
from planner.footprint import footprint_of

__all__ = ["FORWARD", "REVERSE", "draw_footprints"]

FORWARD = (40, 90, 200)
"""The outline's colour where the robot drives forward."""
REVERSE = (230, 120, 20)
"""The outline's colour where it reverses."""


def draw_footprints(
    image: Image.Image,
    analysis: Analysis,
    poses: Any,
    footprint: Any,
    *,
    directions: Any = None,
    cell: int,
    spacing: float = 0.3,
) -> None:
    """Draw ``footprint`` (vertices in the robot's frame, meters) at poses ``(m, 3)`` in meters,
    one outline every ``spacing`` meters along them and at both ends, on a picture of
    ``analysis`` at ``cell`` pixels a cell (as :func:`planner.render.draw` makes it); an outline
    is orange where ``directions`` (1 / -1 per pose) says the robot reverses."""
    P = np.asarray(poses, dtype=np.float64)
    if P.ndim != 2 or P.shape[1:] != (3,) or len(P) == 0 or not np.isfinite(P).all():
        msg = f"poses must be an (m, 3) array of finite [x, y, yaw]; got shape {P.shape!r}"
        raise InvalidInput(msg, field="poses")
    d = np.ones(len(P), np.int64) if directions is None else np.asarray(directions, np.int64)
    vertices = np.array(footprint_of(footprint).vertices)
    frame = analysis.frame
    ox, oy, yaw = frame.origin
    c, s = math.cos(yaw), math.sin(yaw)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(P[:, :2], axis=0).T))])
    marks = np.searchsorted(along, np.arange(0.0, along[-1], spacing))
    pen = ImageDraw.Draw(image)
    for i in sorted({*marks.tolist(), len(P) - 1}):
        x, y, heading = P[i]
        ch, sh = math.cos(heading), math.sin(heading)
        wx = x + ch * vertices[:, 0] - sh * vertices[:, 1] - ox
        wy = y + sh * vertices[:, 0] + ch * vertices[:, 1] - oy
        u, v = (c * wx + s * wy) / frame.resolution, (-s * wx + c * wy) / frame.resolution
        outline = list(zip((u * cell).tolist(), ((analysis.shape[0] - v) * cell).tolist(),
                           strict=True))  # fmt: skip
        pen.polygon(outline, outline=REVERSE if d[i] < 0 else FORWARD, width=max(1, cell // 6))

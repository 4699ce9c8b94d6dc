"""Pictures to find points in meters on: axes in meters along a robot map's picture (x below
it, y on its right, so that the picture's top-left pixel stays the map's), and the window of the
map that is known (real maps are mostly unknown grey around the mapped part)."""

from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from planner.analysis.analyse import Analysis

__all__ = ["known_window", "with_axes"]

Window = tuple[int, int, int, int]
"""Rows ``r0:r1`` and columns ``c0:c1`` of a map: ``(r0, r1, c0, c1)``."""


def known_window(analysis: Analysis, margin: int = 4) -> Window:
    """The rows and columns holding every known cell (free or blocked), ``margin`` cells wider
    on each side within the map; the whole map when none is unknown or all are.

    >>> import planner
    >>> occ = np.full((20, 30), -1, dtype=np.int8); occ[5:8, 10:14] = 0
    >>> known_window(planner.plan(planner.grid_map(occ), (6, 11), (6, 12)).analysis, margin=1)
    (4, 9, 9, 15)
    """
    H, W = analysis.shape
    cs = analysis.cspace
    if cs is None:
        return 0, H, 0, W
    rows, cols = np.nonzero(cs.unknown_cells == 0)
    if len(rows) == 0:
        return 0, H, 0, W
    return (
        max(0, int(rows.min()) - margin),
        min(H, int(rows.max()) + 1 + margin),
        max(0, int(cols.min()) - margin),
        min(W, int(cols.max()) + 1 + margin),
    )


def _step(span_m: float, pixels: float) -> float:
    """A round tick spacing in meters (1, 2 or 5 times a power of ten) about 80 pixels apart."""
    target = span_m * 80 / max(pixels, 1.0)
    step = 10.0 ** math.floor(math.log10(target))
    return min(m * step for m in (1.0, 2.0, 5.0, 10.0) if m * step >= target)


def with_axes(image: Image.Image, analysis: Analysis, cell: int, window: Window) -> Image.Image:
    """``image`` (the map's ``window`` drawn at ``cell`` pixels a cell) with ticks and labels in
    meters: x below it, y on its right. A map whose frame is rotated keeps its picture as it
    is (its axes are not the picture's)."""
    frame = analysis.frame
    ox, oy, yaw = frame.origin
    if yaw != 0:
        return image
    r0, r1, c0, c1 = window
    H = analysis.shape[0]
    res = frame.resolution
    font = ImageFont.load_default(size=13)
    x_lo, x_hi = ox + c0 * res, ox + c1 * res  # the window's edges in meters
    y_lo, y_hi = oy + (H - r1) * res, oy + (H - r0) * res
    label = max(len(f"{v:g} m") for v in (x_lo, x_hi, y_lo, y_hi)) * 8 + 16
    out = Image.new("RGB", (image.width + label, image.height + 44), (255, 255, 255))
    out.paste(image, (0, 0))
    pen = ImageDraw.Draw(out)
    ink = (60, 60, 60)
    pen.line([(0, image.height), (image.width, image.height)], fill=ink)
    pen.line([(image.width, 0), (image.width, image.height)], fill=ink)
    per_m = cell / res  # pixels a meter
    step = _step(x_hi - x_lo, image.width)
    for k in range(math.ceil(x_lo / step), math.floor(x_hi / step) + 1):
        u = (k * step - x_lo) * per_m
        pen.line([(u, image.height), (u, image.height + 5)], fill=ink)
        pen.text((u, image.height + 7), f"{k * step:g}", fill=ink, font=font, anchor="mt")
    step = _step(y_hi - y_lo, image.height)
    for k in range(math.ceil(y_lo / step), math.floor(y_hi / step) + 1):
        v = (y_hi - k * step) * per_m
        pen.line([(image.width, v), (image.width + 5, v)], fill=ink)
        at = min(max(v, 7), image.height - 7)  # within the picture's height
        pen.text((image.width + 8, at), f"{k * step:g}", fill=ink, font=font, anchor="lm")
    pen.text((image.width / 2, image.height + 24), "x (m)", fill=ink, font=font, anchor="mt")
    pen.text((image.width + 8, image.height + 24), "y (m)", fill=ink, font=font, anchor="lt")
    return out

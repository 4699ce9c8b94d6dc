"""Pictures' sizes and frame-only maps: what the picture and obstacle routes share."""

from __future__ import annotations

import math

import numpy as np

import planner
from planner.render import auto_cell
from service.errors import TooLarge

__all__ = ["MAX_IMAGE_PIXELS", "MAX_IMAGE_SIDE", "cell_size", "frame_map"]

MAX_IMAGE_SIDE = 8192
"""Pixels on a picture's longer side at most (the picture must also hold at most
``MAX_IMAGE_PIXELS``: a 4096 x 4096 map at 1 pixel a cell)."""
MAX_IMAGE_PIXELS = 4096 * 4096
"""Pixels of a picture at most (a few seconds to draw and compress, ~50 MB while drawn)."""


def frame_map(frame: planner.MapFrame) -> planner.RobotMap:
    """A map of ``frame`` with no content: what :func:`planner.circle_cells` reads (the frame
    only), without the stored map. The occupancy is a zero-copy broadcast view."""
    return planner.RobotMap(np.broadcast_to(np.int8(0), frame.shape), frame)


def cell_size(shape: tuple[int, int], cell: int | None) -> int:
    """Pixels per cell of a picture: the caller's, within the image limit, or the planner's
    legible default (:func:`planner.render.auto_cell`)."""
    side = max(shape)
    if cell is None:
        return auto_cell(shape)
    if side * cell > MAX_IMAGE_SIDE:
        msg = (
            f"cell {cell} would draw the {shape[0]} x {shape[1]} map {side * cell} pixels wide; "
            f"the limit is {MAX_IMAGE_SIDE} (use cell <= {max(1, MAX_IMAGE_SIDE // side)})"
        )
        raise planner.InvalidInput(msg, field="cell")
    pixels = shape[0] * shape[1] * cell * cell
    if pixels > MAX_IMAGE_PIXELS:
        fits = max(1, math.isqrt(MAX_IMAGE_PIXELS // (shape[0] * shape[1])))
        msg = (
            f"cell {cell} would draw the {shape[0]} x {shape[1]} map in {pixels} pixels; the "
            f"limit is {MAX_IMAGE_PIXELS} (use cell <= {fits})"
        )
        raise TooLarge(msg, field="cell")
    return cell

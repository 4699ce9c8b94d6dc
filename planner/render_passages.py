"""Narrow passages on a picture of a map: their cells tinted violet, each labelled with its
width in meters at its narrowest point (:func:`planner.render.draw` calls these)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw, ImageFont

from planner.analysis.passages import Passage

__all__ = ["PASSAGE_COLOUR", "label_passages", "tint_passages"]

PASSAGE_COLOUR = (150, 80, 220)
"""RGB of a passage's cells (the traversable cells of its neck)."""


def tint_passages(rgb: npt.NDArray[np.uint8], passages: Sequence[Passage]) -> None:
    """Tint the cells of ``passages`` on an ``H x W x 3`` picture of the map, one pixel a cell:
    half the passage colour, half what was there (walls beside them stay readable)."""
    H, W = rgb.shape[:2]
    for p in passages:
        rows, cols = np.divmod(p.cells, W)
        ok = (rows >= 0) & (rows < H)
        rows, cols = rows[ok], cols[ok]
        mixed = (rgb[rows, cols].astype(np.uint16) + PASSAGE_COLOUR) // 2
        rgb[rows, cols] = mixed.astype(np.uint8)


def label_passages(image: Image.Image, passages: Sequence[Passage], *, cell: int) -> None:
    """Write each passage's id and width (``#0 0.62 m``) beside its narrowest cell, on a white
    box, with a violet dot on the cell itself; a label that would cover another or leave the
    picture moves down (or inside it)."""
    pen = ImageDraw.Draw(image)
    font = ImageFont.load_default(size=13)
    placed: list[tuple[float, float, float, float]] = []
    for p in passages:
        x, y = (p.col + 0.5) * cell, (p.row + 0.5) * cell
        k = max(3.0, cell / 2)
        pen.ellipse((x - k, y - k, x + k, y + k), fill=PASSAGE_COLOUR, outline=(255, 255, 255))
        text = f"#{p.id} {p.width_m:.2f} m"
        w, h = font.getlength(text) + 4, 17
        left = min(max(x + k + 2, 0), image.width - w)
        top = min(max(y - h / 2, 0), image.height - h)
        for _ in range(len(placed)):
            if not any(_overlap((left, top, left + w, top + h), box) for box in placed):
                break
            top = top + h + 1 if top + 2 * h + 1 <= image.height else top - h - 1
        placed.append((left, top, left + w, top + h))
        pen.rectangle((left, top, left + w, top + h), fill=(255, 255, 255))
        pen.text((left + 2, top + 1), text, fill=PASSAGE_COLOUR, font=font)


def _overlap(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]

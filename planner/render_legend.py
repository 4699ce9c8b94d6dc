"""A picture's key: the colour of each thing drawn, what each stands for, and the key with a
scale bar in meters added below a picture of a robot map."""

from __future__ import annotations

import math
from collections.abc import Sequence

from PIL import Image, ImageDraw, ImageFont

from planner.analysis.analyse import Analysis
from planner.render_zones import zone_legend

__all__ = ["COLOURS", "LEGEND_NAMES", "Key", "legend_entries", "with_legend"]

#: RGB colour of each thing drawn.
COLOURS: dict[str, tuple[int, int, int]] = {
    "free": (255, 255, 255),
    "obstacle": (0, 0, 0),
    "tunnel": (255, 140, 0),
    "gate": (220, 0, 0),
    "dynamic": (0, 60, 255),
    "path": (0, 170, 0),
    "preview": (170, 225, 170),
    "poses": (0, 120, 220),
    "start": (230, 0, 230),
    "goal": (255, 210, 0),
    "robot": (0, 90, 0),
    "grid": (225, 225, 225),
    "heat": (150, 100, 210),
    "unreachable": (200, 200, 200),
    "unknown": (160, 170, 185),
    "margin": (255, 200, 200),
}


LEGEND_NAMES = {
    "free": "free",
    "obstacle": "blocked",
    "unknown": "unknown",
    "margin": "C-space margin",
    "tunnel": "tight tunnel (sealed)",
    "gate": "gate",
    "path": "path",
    "preview": "planned path",
    "poses": "poses (smooth path)",
    "robot": "robot (footprint)",
    "dynamic": "dynamic obstacle",
    "start": "start",
    "goal": "goal",
}


Key = tuple[tuple[int, int, int], str]


def legend_entries(
    *, path_label: str = "path", preview: bool = False, named: Sequence[Key] = ()
) -> list[Key]:
    """A picture's key: each colour and what it stands for. The green cells are
    ``path_label`` (a robot's trajectory, drawn over its plan); the pale green ones the planned
    path, when a ``preview`` is drawn; ``named`` paths stand in for the green one.

    >>> [label for _, label in legend_entries(path_label="trajectory", preview=True)][6:8]
    ['trajectory', 'planned path']
    """
    names = {**LEGEND_NAMES, "path": path_label}
    skip = {"preview"} if not preview else set()
    if named:
        skip.add("path")
    return [(COLOURS[k], label) for k, label in names.items() if k not in skip] + list(named)


def with_legend(
    image: Image.Image, analysis: Analysis, cell: int, entries: list[Key]
) -> Image.Image:
    """The image with a key of its colours (``entries``) and a scale bar in meters below it."""
    font = ImageFont.load_default(size=14)
    entries = [*entries, *zone_legend(analysis)]
    width = max(image.width, 520)
    pad, box, row = 8, 14, 22
    x = y = pad
    placed = []
    for colour, label in entries:
        w = box + 6 + int(font.getlength(label)) + 16
        if x + w > width - pad:
            x, y = pad, y + row
        placed.append((x, y, colour, label))
        x += w
    height = y + row + 34
    out = Image.new("RGB", (width, image.height + height), (255, 255, 255))
    out.paste(image, (0, 0))
    pen = ImageDraw.Draw(out)
    top = image.height
    for x, y, colour, label in placed:
        pen.rectangle((x, top + y, x + box, top + y + box), fill=colour, outline=(90, 90, 90))
        pen.text((x + box + 6, top + y - 1), label, fill=(0, 0, 0), font=font)
    # The scale bar: a round number of meters, about a fifth of the picture.
    meters_per_px = analysis.frame.resolution / cell
    target = width / 5 * meters_per_px
    step = 10 ** math.floor(math.log10(target))
    length = max(m * step for m in (1, 2, 5) if m * step <= target)
    px = length / meters_per_px
    y0 = top + y + row + 12
    pen.rectangle((pad, y0, pad + px, y0 + 5), fill=(0, 0, 0))
    pen.text((pad + px + 8, y0 - 6), f"{length:g} m", fill=(0, 0, 0), font=font)
    res = analysis.frame.resolution
    pen.text(
        (pad + px + 70, y0 - 6),
        f"{analysis.shape[1]} x {analysis.shape[0]} cells of {res:g} m",
        fill=(90, 90, 90),
        font=font,
    )
    return out

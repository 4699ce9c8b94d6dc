"""Zones in pictures (docs/zones.md): keepout polygons hatched red, speed zones tinted amber and
labelled with their ``max_speed``; what :func:`planner.render.draw` adds on a zoned map.

>>> from planner import analyse_map, grid_map, zone_map
>>> m = zone_map(grid_map([[0] * 8] * 8, resolution=0.5),
...              keepout=[[(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)]])
>>> big = np.full((80, 80, 3), 255, dtype=np.uint8)
>>> paint_zones(big, analyse_map(m), 10)
>>> big[75, 3].tolist(), big[75, 5].tolist()   # hatched: red lines on pale red
([200, 0, 0], [255, 205, 205])
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw, ImageFont

from planner.analysis.analyse import Analysis
from planner.maps.polygons import Polygon, lattice, polygon_cells

__all__ = ["ZONE_COLOURS", "draw_zone_outlines", "paint_zones", "zone_legend"]

#: RGB colours of zones: keepout lines, keepout ground, speed zones.
ZONE_COLOURS: dict[str, tuple[int, int, int]] = {
    "keepout": (200, 0, 0),
    "keepout_ground": (255, 205, 205),
    "speed": (230, 150, 0),
}
HATCH = 6
"""Pixels between two hatch lines of a keepout zone."""


def paint_zones(big: npt.NDArray[np.uint8], analysis: Analysis, cell: int) -> None:
    """Paint a zoned map's zones on its picture ``big`` (``cell`` pixels a cell), in place:
    speed-zone cells tinted amber, keepout-polygon cells pale red crossed by red diagonal
    hatching (a keepout mask's cells stay drawn as the blocked cells they are)."""
    zones = analysis.zones
    if zones is None:
        return
    frame = analysis.frame
    amber = np.array(ZONE_COLOURS["speed"], dtype=np.float64)
    for zone in zones.speed:
        cells = _pixels(polygon_cells(frame, zone.polygon), cell)
        big[cells] = (0.7 * big[cells] + 0.3 * amber).round().astype(np.uint8)
    if not zones.keepout:
        return
    keep = np.zeros(frame.shape, dtype=np.bool_)
    for polygon in zones.keepout:
        keep |= polygon_cells(frame, polygon)
    pixels = _pixels(keep, cell)
    h, w = pixels.shape
    rows, cols = np.ogrid[:h, :w]
    hatch = (rows + cols) % HATCH < max(1, HATCH // 3)
    big[pixels] = ZONE_COLOURS["keepout_ground"]
    big[pixels & hatch] = ZONE_COLOURS["keepout"]


def _pixels(cells: npt.NDArray[np.bool_], cell: int) -> npt.NDArray[np.bool_]:
    out: npt.NDArray[np.bool_] = np.repeat(np.repeat(cells, cell, axis=0), cell, axis=1)
    return out


def _points(analysis: Analysis, polygon: Polygon, cell: int) -> list[tuple[float, float]]:
    """A polygon's vertices in the picture's pixels (a cell's center at its pixels' center)."""
    cols, rows = lattice(analysis.frame, polygon)
    return list(zip(((cols + 0.5) * cell).tolist(), ((rows + 0.5) * cell).tolist(), strict=True))


def draw_zone_outlines(image: Image.Image, analysis: Analysis, cell: int) -> None:
    """Outline each zone (keepout red, speed amber) and label each speed zone with its
    ``max_speed`` at its vertices' mean."""
    zones = analysis.zones
    if zones is None:
        return
    pen = ImageDraw.Draw(image)
    width = max(2, cell // 3)
    for polygon in zones.keepout:
        points = _points(analysis, polygon, cell)
        pen.line([*points, points[0]], fill=ZONE_COLOURS["keepout"], width=width)
    font = ImageFont.load_default(size=max(12, min(28, 2 * cell + 8)))
    for zone in zones.speed:
        points = _points(analysis, zone.polygon, cell)
        pen.line([*points, points[0]], fill=ZONE_COLOURS["speed"], width=width)
        x = sum(p[0] for p in points) / len(points)
        y = sum(p[1] for p in points) / len(points)
        label = f"{zone.max_speed:g} m/s"
        box = pen.textbbox((x, y), label, font=font, anchor="mm")
        pad = 3
        pen.rectangle(
            (box[0] - pad, box[1] - pad, box[2] + pad, box[3] + pad),
            fill=(255, 255, 255),
            outline=ZONE_COLOURS["speed"],
        )
        pen.text((x, y), label, fill=(0, 0, 0), font=font, anchor="mm")


def zone_legend(analysis: Analysis) -> list[tuple[tuple[int, int, int], str]]:
    """The legend's entries for the zones a map has."""
    zones = analysis.zones
    if zones is None:
        return []
    out = []
    if zones.keepout:  # a keepout mask's cells are drawn as the blocked cells they are
        out.append((ZONE_COLOURS["keepout"], "keepout zone"))
    if zones.speed:
        slowest = min(z.max_speed for z in zones.speed)
        out.append((ZONE_COLOURS["speed"], f"speed zone (from {slowest:g} m/s)"))
    return out

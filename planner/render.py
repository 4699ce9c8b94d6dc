"""Pictures like the paper's figures: PNG of a map, a plan or a robot's progress; GIF of an episode.

Colours follow the paper: obstacles black, sealed tight-tunnel cells orange, dynamic obstacles
blue, the path green; gates are a red line across the diagonal gap, the start a magenta disc and
the goal a gold disc. Optionally a heat map of ``clean`` or ``kw`` tints the free cells.

>>> from planner import plan
>>> png = render_plan(plan([[0, 0, 0], [1, 1, 0], [0, 0, 0]], [0, 0], [2, 0]), cell=4)
>>> png[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
True
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw

from planner.analysis.analyse import Analysis
from planner.analysis.passages import Passage
from planner.errors import InvalidInput, quote
from planner.motion.robots import robot_of
from planner.plans.planning import Plan
from planner.plans.whole_wave import Wave
from planner.render_axes import known_window, with_axes
from planner.render_legend import COLOURS, legend_entries, with_legend
from planner.render_passages import PASSAGE_COLOUR, label_passages, tint_passages
from planner.render_shapes import draw_footprints
from planner.render_zones import draw_zone_outlines, paint_zones
from planner.stepping.session import Session
from planner.stepping.simulation import Episode

__all__ = [
    "Field",
    "auto_cell",
    "draw",
    "draw_poses",
    "render_episode",
    "render_map",
    "render_plan",
]

Field = Literal["clean", "kw"]


MAX_CELL = 64
OPTIMIZE_PIXELS = 1 << 20
"""Pictures up to this many pixels are compressed as small as zlib can; bigger ones faster."""

#: The longer side, in pixels, that :func:`auto_cell` aims at.
TARGET_SIDE = 1200

#: Labelled paths drawn as lines: ``(cells, rgb, label)``.
LabelledPath = tuple[Any, tuple[int, int, int], str]


def auto_cell(shape: tuple[int, int]) -> int:
    """Pixels per cell for a legible picture: about ``TARGET_SIDE`` pixels on the longer side,
    at most 24 a cell (a 10 x 10 map), at least 1 (a map of more than 1200 cells a side).

    >>> auto_cell((10, 10)), auto_cell((307, 604)), auto_cell((4000, 3000))
    (24, 2, 1)
    """
    return max(1, min(24, round(TARGET_SIDE / max(shape))))


def draw(
    analysis: Analysis,
    *,
    path: Any = None,
    preview: Any = None,
    dynamic_obstacles: Any = None,
    start: Any = None,
    goal: Any = None,
    robot: Any = None,
    field: Field | None = None,
    wave: Wave | None = None,
    cell: int | None = 10,
    paths: Sequence[LabelledPath] = (),
    legend: bool | None = None,
    poses: Any = None,
    path_label: str = "path",
    passages: Sequence[Passage] = (),
    crop: bool = False,
    footprint: Any = None,
    directions: Any = None,
) -> Image.Image:
    """Draw a map's ``analysis`` as an RGB image of ``cell`` x ``cell`` pixels per map cell
    (``None``: :func:`auto_cell`).

    ``path`` cells are filled green, ``preview`` cells pale green under them (lines through the
    cells' centers below 6 pixels a cell); ``dynamic_obstacles`` cells blue; ``start``, ``goal``
    and the ``robot``'s cell are discs. ``field`` tints free cells by ``analysis.clean`` or by
    ``wave.kw`` (``wave`` is then required). ``paths`` are more paths drawn as labelled lines.
    ``poses`` (``(m, 3)`` ``[x, y, yaw]`` in meters, a plan's :attr:`~planner.Plan.poses`) are
    drawn as a thin blue line over the cells, with the last pose's heading as an arrow, and
    with a ``footprint`` (vertices in the robot's frame, meters) its outline along them, orange
    where ``directions`` says the robot reverses (:mod:`planner.render_shapes`).
    ``passages`` (:func:`planner.find_passages`) are tinted violet, labelled with their width.
    On a robot map, unknown cells are grey-blue, the configuration space's margin (free cells
    the robot's center cannot reach) pink, the robot's footprint a circle; ``legend`` (default:
    on for robot maps) adds a key and a scale bar in meters below the map, the green cells
    named ``path_label``, and axes in meters below and right of it; ``crop`` keeps only the
    known part of the map (:func:`planner.render_axes.known_window`). The robot's disc is
    smaller than the start's and the goal's, which
    show round it when it stands on them. On a zoned map,
    keepout polygons are hatched red and speed zones tinted amber, labelled with their
    ``max_speed`` (:mod:`planner.render_zones`).

    >>> from planner import analyse
    >>> image = draw(analyse([[0, 1], [1, 0]]), cell=3)   # a gate: the red line across it
    >>> image.size, image.getpixel((1, 1)), image.getpixel((4, 1))
    ((6, 6), (220, 0, 0), (0, 0, 0))
    """
    if cell is None:
        cell = auto_cell(analysis.shape)
    if isinstance(cell, bool) or not isinstance(cell, int) or not 1 <= cell <= MAX_CELL:
        msg = f"cell must be an integer number of pixels in [1, {MAX_CELL}]; got {quote(cell)}"
        raise InvalidInput(msg, field="cell")
    H, W = analysis.shape
    rgb = np.empty((H, W, 3), dtype=np.uint8)
    rgb[:] = COLOURS["free"]
    if field is not None:
        rgb[:] = _heat(analysis, field, wave)
    cs = analysis.cspace
    if cs is not None:
        rgb[cs.margin] = COLOURS["margin"]
        rgb[(cs.blocked == 1) & (cs.unknown_cells == 0)] = COLOURS["obstacle"]
        rgb[cs.unknown_cells == 1] = COLOURS["unknown"]
    else:
        rgb[analysis.state == 1] = COLOURS["obstacle"]
    if analysis.seal_tunnels:  # unsealed tunnel cells are ordinary free cells to the planner
        rgb[analysis.state == 2] = COLOURS["tunnel"]
    tint_passages(rgb, passages)
    lines_: list[LabelledPath] = []
    for cells, colour in ((preview, "preview"), (path, "path"), (dynamic_obstacles, "dynamic")):
        if cells is not None and cell < 6 and colour != "dynamic":
            lines_.append((cells, COLOURS[colour], colour))
        elif cells is not None:
            rc = _cells(cells, analysis.shape, colour)
            rgb[rc[:, 0], rc[:, 1]] = COLOURS[colour]
    big = np.repeat(np.repeat(rgb, cell, axis=0), cell, axis=1)
    if cell >= 6:  # grid lines only where they leave the cells readable, and not over obstacles
        open_ = np.repeat(np.repeat(analysis.state != 1, cell, axis=0), cell, axis=1)
        lines = np.zeros(open_.shape, dtype=bool)
        lines[cell::cell, :] = True
        lines[:, cell::cell] = True
        big[lines & open_] = COLOURS["grid"]
    paint_zones(big, analysis, cell)
    _draw_gates(big, analysis.gate_cells().reshape(-1, 4), cell)
    image = Image.fromarray(big, "RGB")
    draw_zone_outlines(image, analysis, cell)
    pen = ImageDraw.Draw(image)
    half = cell / 2
    for cells, rgb_, _ in [*lines_, *paths]:
        rc = _cells(cells, analysis.shape, "path")
        points = [(c * cell + half, r * cell + half) for r, c in rc.tolist()]
        pen.line(points, fill=rgb_, width=max(3, cell // 2), joint="curve")
    if poses is not None:
        draw_poses(image, analysis, poses, cell=cell)
        if footprint is not None:
            draw_footprints(image, analysis, poses, footprint, directions=directions, cell=cell)
    label_passages(image, passages, cell=cell)
    radius = cs.robot_radius / cs.resolution * cell if cs is not None else 0.0
    for cells, colour in ((start, "start"), (goal, "goal"), (robot, "robot")):
        if cells is not None:
            (r, c), *_ = _cells([cells], analysis.shape, colour).tolist()
            small = colour == "robot"  # inside the start's or the goal's disc, which ring it
            if cell < 6:  # a disc bigger than the cell, or it would not show
                x, y, k = c * cell + half, r * cell + half, 3 if small else 5
                pen.ellipse((x - k, y - k, x + k, y + k), fill=COLOURS[colour], outline=(0, 0, 0))
            else:
                inset = max(cell // 3, 1) if small else max(cell // 8, 0)
                pen.ellipse(_box(r, c, cell, inset), fill=COLOURS[colour], outline=(0, 0, 0))
            if radius >= 1 and colour in ("start", "robot"):  # the robot's footprint
                x, y = c * cell + half, r * cell + half
                pen.ellipse(
                    (x - radius, y - radius, x + radius, y + radius),
                    outline=COLOURS["robot"],
                    width=2,
                )
    window = known_window(analysis) if crop else (0, H, 0, W)
    if crop:
        r0, r1, c0, c1 = window
        image = image.crop((c0 * cell, r0 * cell, c1 * cell, r1 * cell))
    if legend if legend is not None else cs is not None:
        image = with_axes(image, analysis, cell, window)
        named = [(rgb_, label) for _, rgb_, label in paths if label]
        keys = legend_entries(path_label=path_label, preview=preview is not None, named=named)
        if passages:
            keys.append((PASSAGE_COLOUR, "narrow passage (width)"))
        image = with_legend(image, analysis, cell, keys)
    return image


def render_map(
    analysis: Analysis,
    *,
    field: Field | None = None,
    wave: Wave | None = None,
    cell: int | None = None,
    passages: Sequence[Passage] = (),
    crop: bool = False,
) -> bytes:
    """PNG bytes of a map with its analysis: obstacles, sealed tunnels, gates (the map endpoint),
    and ``passages`` labelled with their width (``crop``: the known part only).

    >>> from planner import analyse
    >>> render_map(analyse([[0]]), cell=2)[1:4]
    b'PNG'
    """
    image = draw(analysis, field=field, wave=wave, cell=cell, passages=passages, crop=crop)
    return _png(image)


def render_plan(
    plan: Plan,
    *,
    trajectory: Any = None,
    dynamic_obstacles: Any = None,
    field: Field | None = None,
    cell: int | None = None,
    poses: bool = True,
    passages: Sequence[Passage] = (),
    crop: bool = False,
) -> bytes:
    """PNG bytes of a plan: its map, its preview path and, when given, the robot's ``trajectory``
    so far and the ``dynamic_obstacles``' cells (the plan endpoint).

    With no ``trajectory`` the preview is drawn as the path (green); with one, the trajectory is
    green and the preview pale green beneath it, and the legend (on robot maps) says so. The
    plan's poses (unless ``poses`` is false) are a blue line over them, with a footprint or a
    car motion the robot's outline along them every 0.3 m; ``passages`` (those it
    crosses, say) are labelled with their width; ``crop`` keeps the known part of the map.
    """
    path, preview, robot = plan.path, None, None
    shape = robot_of(plan.params, plan.analysis.frame.resolution)
    if trajectory is not None:
        path = _cells(trajectory, plan.analysis.shape, "trajectory")
        if len(path) == 0:
            raise InvalidInput("trajectory must hold at least the start cell; got none")
        preview, robot = plan.path, path[-1]
    image = draw(
        plan.analysis,
        path=path,
        preview=preview,
        dynamic_obstacles=dynamic_obstacles,
        start=plan.start,
        goal=plan.goal,
        robot=robot,
        field=field,
        wave=plan.wave,
        cell=cell,
        poses=plan.poses if poses else None,
        path_label="path" if trajectory is None else "trajectory (so far)",
        passages=passages,
        crop=crop,
        footprint=None if shape is None else shape.footprint.vertices,
        directions=plan.directions if poses and shape is not None else None,
    )
    return _png(image)


def render_episode(episode: Episode, *, cell: int = 8, frame_ms: int = 80) -> bytes:
    """Animated GIF bytes of a simulated ``episode``: one frame per step, the robot's trail
    green, the obstacles blue, the plan's path pale green.

    The robot's position at each step is recovered by replaying the recorded obstacle cells
    through a fresh :class:`~planner.Session`: the decision is deterministic, so the replay is
    exact, and it is checked against the episode's trajectory.
    """
    if episode.dynamic_obstacles.shape[0] == 0:
        raise InvalidInput("the episode was run without record; it has no obstacle cells to draw")
    if isinstance(frame_ms, bool) or not isinstance(frame_ms, int) or frame_ms < 10:
        raise InvalidInput(f"frame_ms must be an integer >= 10; got {quote(frame_ms)}")
    plan = episode.plan
    session = Session(plan, poses=False)
    frames = []
    for t, obstacles in enumerate(episode.dynamic_obstacles):
        if t > 0:
            session.step(obstacles)
        trail = np.asarray(session.state.trajectory, dtype=np.int64)
        image = draw(
            plan.analysis,
            path=trail,
            preview=plan.path,
            dynamic_obstacles=obstacles,
            start=plan.start,
            goal=plan.goal,
            robot=session.state.position,
            cell=cell,
        )
        frames.append(image.convert("P", palette=Image.Palette.ADAPTIVE))
    if not np.array_equal(np.asarray(session.state.trajectory), episode.trajectory):
        raise AssertionError("replaying the episode did not reproduce its trajectory")  # a bug
    out = io.BytesIO()
    frames[0].save(
        out, format="GIF", save_all=True, append_images=frames[1:], duration=frame_ms, loop=0
    )
    return out.getvalue()


def _heat(analysis: Analysis, field: Field, wave: Wave | None) -> npt.NDArray[np.uint8]:
    if field == "clean":
        values = analysis.clean.astype(np.float64)
    elif field == "kw":
        if wave is None:
            raise InvalidInput("field 'kw' needs the goal wave; pass wave=", field="field")
        values = np.asarray(wave.kw, dtype=np.float64)
    else:
        raise InvalidInput(f"field must be 'clean' or 'kw'; got {quote(field)}", field="field")
    finite = np.isfinite(values)
    top = float(values[finite].max()) if finite.any() else 0.0
    share = np.where(finite, values, 0.0) / top if top > 0 else np.zeros_like(values)
    free, heat = np.array(COLOURS["free"], float), np.array(COLOURS["heat"], float)
    rgb = free + share[..., None] * (heat - free)
    rgb[~finite] = COLOURS["unreachable"]
    out: npt.NDArray[np.uint8] = rgb.round().astype(np.uint8)
    return out


def _cells(cells: Any, shape: tuple[int, int], name: str) -> npt.NDArray[np.int64]:
    try:
        rc = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
    except (TypeError, ValueError):
        msg = f"{name} must be [row, col] cells; got {quote(cells)}"
        raise InvalidInput(msg, field=name) from None
    inside = (rc >= 0).all(axis=1) & (rc[:, 0] < shape[0]) & (rc[:, 1] < shape[1])
    if not inside.all():
        bad = rc[np.flatnonzero(~inside)[0]].tolist()
        msg = f"{name} cell {bad} is outside the {shape[0]} x {shape[1]} map"
        raise InvalidInput(msg, field=name)
    return rc


def _draw_gates(big: npt.NDArray[np.uint8], gates: npt.NDArray[Any], cell: int) -> None:
    """Each gate as a red line joining its two free cells' centres, with a dot on each: drawn
    for all gates at once, one numpy pass per pixel of a cell (a map can have millions)."""
    if not len(gates):
        return
    colour = COLOURS["gate"]
    r1, c1, r2, c2 = (gates[:, i].astype(np.int64) for i in range(4))
    height, width = big.shape[:2]
    half = cell // 2
    thick = max(1, cell // 4)
    dr, dc = np.sign(r2 - r1), np.sign(c2 - c1)
    for t in range(cell + 1):  # along the diagonal, centre to centre
        y = r1 * cell + half + t * dr
        for k in range(thick):
            x = c1 * cell + half + t * dc + k - thick // 2
            ok = (y >= 0) & (y < height) & (x >= 0) & (x < width)
            big[y[ok], x[ok]] = colour
    inset = cell // 3  # a dot on each gap cell, visible at any scale
    span = np.arange(inset, cell - inset)
    if span.size:
        for r, c in ((r1, c1), (r2, c2)):
            rows = (r[:, None] * cell + span)[:, :, None]
            cols = (c[:, None] * cell + span)[:, None, :]
            big[rows, cols] = colour


def draw_poses(image: Image.Image, analysis: Analysis, poses: Any, *, cell: int) -> None:
    """Draw poses ``(m, 3)`` ``[x, y, yaw]`` in meters on a picture of ``analysis`` at ``cell``
    pixels a cell (as :func:`draw` makes it): a blue line, the last heading an arrow."""
    pen = ImageDraw.Draw(image)
    P = np.asarray(poses, dtype=np.float64)
    if P.ndim != 2 or P.shape[1:] != (3,) or len(P) == 0 or not np.isfinite(P).all():
        msg = f"poses must be an (m, 3) array of finite [x, y, yaw]; got shape {P.shape!r}"
        raise InvalidInput(msg, field="poses")
    frame = analysis.frame
    ox, oy, yaw = frame.origin
    cos, sin = math.cos(yaw), math.sin(yaw)
    dx, dy = P[:, 0] - ox, P[:, 1] - oy
    u = (cos * dx + sin * dy) / frame.resolution  # cells from the map's left edge
    v = (-sin * dx + cos * dy) / frame.resolution  # cells from its bottom edge
    points = list(zip((u * cell).tolist(), ((analysis.shape[0] - v) * cell).tolist(), strict=True))
    width = max(2, cell // 4)
    colour = COLOURS["poses"]
    if len(points) > 1:
        pen.line(points, fill=colour, width=width, joint="curve")
    # The heading in pixels: y grows downwards, and the map's yaw turns the frame.
    heading = P[-1, 2] - yaw
    size = max(8.0, 2.5 * cell)
    x, y = points[-1]
    tip = (x + size * math.cos(heading), y - size * math.sin(heading))
    pen.line([(x, y), tip], fill=colour, width=width)
    for side in (2.6, -2.6):
        a = heading + side
        pen.line([tip, (tip[0] + size / 3 * math.cos(a), tip[1] - size / 3 * math.sin(a))],
                 fill=colour, width=width)  # fmt: skip


def _box(r: int, c: int, cell: int, inset: int) -> Sequence[int]:
    return (
        c * cell + inset,
        r * cell + inset,
        (c + 1) * cell - 1 - inset,
        (r + 1) * cell - 1 - inset,
    )


def _png(image: Image.Image) -> bytes:
    out = io.BytesIO()
    # zlib's best effort costs ~10 us a pixel (100 s for a 4096 x 4096 map, measured) for ~20%
    # fewer bytes: worth it only on small pictures.
    if image.width * image.height <= OPTIMIZE_PIXELS:
        image.save(out, format="PNG", optimize=True)
    else:
        image.save(out, format="PNG", compress_level=6)
    return out.getvalue()

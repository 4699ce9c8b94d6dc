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
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw

from planner._errors import InvalidInput, quote
from planner.analysis import Analysis, Wave
from planner.planning import Plan
from planner.session import Session
from planner.simulation import Episode

__all__ = [
    "COLOURS",
    "Field",
    "draw",
    "render_episode",
    "render_map",
    "render_plan",
]

Field = Literal["clean", "kw"]

#: RGB colour of each thing drawn.
COLOURS: dict[str, tuple[int, int, int]] = {
    "free": (255, 255, 255),
    "obstacle": (0, 0, 0),
    "tunnel": (255, 140, 0),
    "gate": (220, 0, 0),
    "dynamic": (0, 60, 255),
    "path": (0, 170, 0),
    "preview": (170, 225, 170),
    "start": (230, 0, 230),
    "goal": (255, 210, 0),
    "robot": (0, 90, 0),
    "grid": (225, 225, 225),
    "heat": (150, 100, 210),
    "unreachable": (200, 200, 200),
}

MAX_CELL = 64
OPTIMIZE_PIXELS = 1 << 20
"""Pictures up to this many pixels are compressed as small as zlib can; bigger ones faster."""


def draw(
    analysis: Analysis,
    *,
    path: Any = None,
    preview: Any = None,
    dynamic: Any = None,
    start: Any = None,
    goal: Any = None,
    robot: Any = None,
    field: Field | None = None,
    wave: Wave | None = None,
    cell: int = 10,
) -> Image.Image:
    """Draw a map's ``analysis`` as an RGB image of ``cell`` x ``cell`` pixels per map cell.

    ``path`` cells are filled green, ``preview`` cells pale green under them; ``dynamic`` cells
    blue; ``start``, ``goal`` and the ``robot``'s cell are discs. ``field`` tints free cells by
    ``analysis.clean`` or by ``wave.kw`` (``wave`` is then required).

    >>> from planner import analyse
    >>> image = draw(analyse([[0, 1], [1, 0]]), cell=3)   # a gate: the red line across it
    >>> image.size, image.getpixel((1, 1)), image.getpixel((4, 1))
    ((6, 6), (220, 0, 0), (0, 0, 0))
    """
    if isinstance(cell, bool) or not isinstance(cell, int) or not 1 <= cell <= MAX_CELL:
        msg = f"cell must be an integer number of pixels in [1, {MAX_CELL}]; got {quote(cell)}"
        raise InvalidInput(msg, field="cell")
    H, W = analysis.shape
    rgb = np.empty((H, W, 3), dtype=np.uint8)
    rgb[:] = COLOURS["free"]
    if field is not None:
        rgb[:] = _heat(analysis, field, wave)
    rgb[analysis.state == 1] = COLOURS["obstacle"]
    if analysis.seal_tunnels:  # unsealed tunnel cells are ordinary free cells to the planner
        rgb[analysis.state == 2] = COLOURS["tunnel"]
    for cells, colour in ((preview, "preview"), (path, "path"), (dynamic, "dynamic")):
        if cells is not None:
            rc = _cells(cells, analysis.shape, colour)
            rgb[rc[:, 0], rc[:, 1]] = COLOURS[colour]
    big = np.repeat(np.repeat(rgb, cell, axis=0), cell, axis=1)
    if cell >= 6:  # grid lines only where they leave the cells readable, and not over obstacles
        open_ = np.repeat(np.repeat(analysis.state != 1, cell, axis=0), cell, axis=1)
        lines = np.zeros(open_.shape, dtype=bool)
        lines[cell::cell, :] = True
        lines[:, cell::cell] = True
        big[lines & open_] = COLOURS["grid"]
    _draw_gates(big, analysis.gate_cells().reshape(-1, 4), cell)
    image = Image.fromarray(big, "RGB")
    pen = ImageDraw.Draw(image)
    for cells, colour in ((start, "start"), (goal, "goal"), (robot, "robot")):
        if cells is not None:
            (r, c), *_ = _cells([cells], analysis.shape, colour).tolist()
            pen.ellipse(
                _box(r, c, cell, max(cell // 8, 0)), fill=COLOURS[colour], outline=(0, 0, 0)
            )
    return image


def render_map(
    analysis: Analysis, *, field: Field | None = None, wave: Wave | None = None, cell: int = 10
) -> bytes:
    """PNG bytes of a map with its analysis: obstacles, sealed tunnels, gates (the map endpoint).

    >>> from planner import analyse
    >>> render_map(analyse([[0]]), cell=2)[1:4]
    b'PNG'
    """
    return _png(draw(analysis, field=field, wave=wave, cell=cell))


def render_plan(
    plan: Plan,
    *,
    trajectory: Any = None,
    dynamic: Any = None,
    field: Field | None = None,
    cell: int = 10,
) -> bytes:
    """PNG bytes of a plan: its map, its preview path and, when given, the robot's ``trajectory``
    so far and the ``dynamic`` obstacles' cells (the plan endpoint).

    With no ``trajectory`` the preview is drawn as the path (green); with one, the trajectory is
    green and the preview pale green beneath it.
    """
    path, preview, robot = plan.path, None, None
    if trajectory is not None:
        path = _cells(trajectory, plan.analysis.shape, "trajectory")
        if len(path) == 0:
            raise InvalidInput("trajectory must hold at least the start cell; got none")
        preview, robot = plan.path, path[-1]
    image = draw(
        plan.analysis,
        path=path,
        preview=preview,
        dynamic=dynamic,
        start=plan.start,
        goal=plan.goal,
        robot=robot,
        field=field,
        wave=plan.wave,
        cell=cell,
    )
    return _png(image)


def render_episode(episode: Episode, *, cell: int = 8, frame_ms: int = 80) -> bytes:
    """Animated GIF bytes of a simulated ``episode``: one frame per step, the robot's trail
    green, the obstacles blue, the plan's path pale green.

    The robot's position at each step is recovered by replaying the recorded obstacle cells
    through a fresh :class:`~planner.Session`: the decision is deterministic, so the replay is
    exact, and it is checked against the episode's trajectory.
    """
    if episode.obstacles.shape[0] == 0:
        raise InvalidInput("the episode was run without record; it has no obstacle cells to draw")
    if isinstance(frame_ms, bool) or not isinstance(frame_ms, int) or frame_ms < 10:
        raise InvalidInput(f"frame_ms must be an integer >= 10; got {quote(frame_ms)}")
    plan = episode.plan
    session = Session(plan)
    frames = []
    for t, obstacles in enumerate(episode.obstacles):
        if t > 0:
            session.step(obstacles)
        trail = np.asarray(session.state.trajectory, dtype=np.int64)
        image = draw(
            plan.analysis,
            path=trail,
            preview=plan.path,
            dynamic=obstacles,
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

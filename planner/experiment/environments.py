"""The paper's six 50 x 50 test environments (section 4.2), re-created as seeded generators.

The paper describes its maps only in words and does not publish them, so these are re-creations
in their spirit; Table 1's five start/goal pairs per environment (``TABLE1``, ``[row, col]`` as
printed) are free and connected on every map generated here.

>>> grid = environment(6, seed=0)
>>> grid.shape, grid.dtype.name
((50, 50), 'uint8')
>>> bool((grid == environment(6, seed=0)).all()), bool((grid == environment(6, seed=1)).all())
(True, False)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import analyse
from planner.errors import InvalidInput, quote
from planner.plans.whole_wave import goal_wave

__all__ = ["DESCRIPTIONS", "SIZE", "TABLE1", "Pair", "connected", "environment"]

SIZE = 50

Cell = tuple[int, int]
Pair = tuple[Cell, Cell]
Grid = npt.NDArray[np.uint8]

#: Table 1 of the paper: the five (start, goal) pairs of each environment, ``[row, col]``.
TABLE1: dict[int, tuple[Pair, ...]] = {
    1: (((37, 8), (5, 38)), ((45, 6), (19, 41)), ((0, 42), (6, 2)), ((3, 2), (2, 48)),
        ((21, 14), (21, 37))),
    2: (((24, 24), (35, 38)), ((34, 38), (25, 13)), ((18, 21), (32, 42)), ((33, 18), (25, 35)),
        ((42, 3), (0, 37))),
    3: (((28, 7), (26, 26)), ((14, 48), (33, 16)), ((43, 47), (23, 15)), ((8, 0), (48, 46)),
        ((48, 24), (1, 24))),
    4: (((3, 6), (47, 14)), ((25, 22), (47, 14)), ((41, 1), (2, 3)), ((5, 49), (18, 0)),
        ((27, 1), (16, 48))),
    5: (((22, 13), (27, 17)), ((33, 36), (22, 12)), ((11, 42), (31, 8)), ((1, 48), (49, 1)),
        ((26, 4), (23, 48))),
    6: (((48, 49), (1, 49)), ((0, 49), (0, 3)), ((0, 0), (49, 49)), ((0, 49), (49, 0)),
        ((39, 2), (15, 37))),
}  # fmt: skip

#: One line per environment, after the paper's section 4.2.
DESCRIPTIONS: dict[int, str] = {
    1: "many random shapes, a horizontal band across the middle with a few openings",
    2: "overlapping circles and rings, some rings open",
    3: "curves (arcs) open in several directions",
    4: "big blocks with holes opening downward and a gate above each",
    5: "curves (sine strokes) across the map",
    6: "horizontal bars with openings",
}

MAX_ATTEMPTS = 200

_ROWS, _COLS = np.mgrid[0:SIZE, 0:SIZE]


def environment(number: int, *, seed: int = 0) -> Grid:
    """A 50 x 50 map (0 free, 1 blocked) of environment ``number`` (1-6), reproducible by ``seed``.

    Table 1's endpoints and their neighbours are cleared; a draw that leaves any pair
    unconnected is discarded and the next sub-seed drawn.

    >>> pairs = TABLE1[1]
    >>> connected(environment(1, seed=3), pairs)
    True
    >>> environment(7)
    Traceback (most recent call last):
    ...
    planner.errors.InvalidInput: environment number must be one of 1-6; got 7
    """
    if isinstance(number, bool) or number not in _GENERATORS:
        raise InvalidInput(f"environment number must be one of 1-6; got {quote(number)}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InvalidInput(f"seed must be a non-negative integer; got {quote(seed)}")
    pairs = TABLE1[number]
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng([number, seed, attempt])
        grid = _GENERATORS[number](rng)
        for cell in {cell for pair in pairs for cell in pair}:
            r, c = cell
            grid[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2] = 0
        if connected(grid, pairs):
            return grid
    raise AssertionError(f"environment {number} seed {seed}: no connected draw")  # a bug


def connected(grid: Grid, pairs: tuple[Pair, ...]) -> bool:
    """Whether every (start, goal) pair is free and joined by 8-connected moves that cut no corner.

    >>> connected(np.array([[0, 1], [1, 0]], dtype=np.uint8), (((0, 0), (1, 1)),))
    False
    """
    analysis = analyse(grid, seal_tunnels=False, clean_weight=0.0, clean_radius=1)
    for start, goal in pairs:
        if grid[start] or grid[goal]:
            return False
        if not np.isfinite(goal_wave(analysis, goal).k[start]):
            return False
    return True


def _disc(r: float, c: float, radius: float) -> npt.NDArray[np.bool_]:
    return np.asarray(np.hypot(_ROWS - r, _COLS - c) <= radius)


def _ring(
    rng: np.random.Generator, r: float, c: float, radius: float, width: float, gap: float
) -> npt.NDArray[np.bool_]:
    """A ring (or arc), open over ``gap`` radians around a random direction."""
    d = np.hypot(_ROWS - r, _COLS - c)
    band = np.abs(d - radius) <= width / 2
    facing = rng.uniform(-np.pi, np.pi)
    angle = np.arctan2(_ROWS - r, _COLS - c)
    off = np.abs((angle - facing + np.pi) % (2 * np.pi) - np.pi)
    return np.asarray(band & (off > gap / 2))


def _band_with_openings(
    rng: np.random.Generator, grid: Grid, top: int, thick: int, widths: list[int]
) -> None:
    """A full-width horizontal bar with openings of the given widths at random columns."""
    grid[top : top + thick, :] = 1
    for w in widths:
        c = int(rng.integers(0, SIZE - w + 1))
        grid[top : top + thick, c : c + w] = 0


def _random_shapes(rng: np.random.Generator) -> Grid:
    grid = np.zeros((SIZE, SIZE), dtype=np.uint8)
    for _ in range(int(rng.integers(80, 95))):
        r, c = (int(v) for v in rng.integers(0, SIZE, size=2))
        kind = rng.integers(0, 4)
        if kind == 0:  # rectangle
            h, w = (int(v) for v in rng.integers(1, 5, size=2))
            grid[r : r + h, c : c + w] = 1
        elif kind == 1:  # blob
            grid[_disc(r, c, rng.uniform(1.0, 2.6))] = 1
        elif kind == 2:  # plus
            arm = int(rng.integers(1, 3))
            grid[max(r - arm, 0) : r + arm + 1, c] = 1
            grid[r, max(c - arm, 0) : c + arm + 1] = 1
        else:  # L
            n = int(rng.integers(2, 5))
            grid[r : r + n, c] = 1
            grid[min(r + n - 1, SIZE - 1), c : c + n] = 1
    # The middle band: a wide opening so a wide path exists, narrow ones that make tunnels.
    _band_with_openings(rng, grid, 24, 2, [int(rng.integers(3, 6)), 1, 1, 2])
    return grid


def _circles(rng: np.random.Generator) -> Grid:
    grid = np.zeros((SIZE, SIZE), dtype=np.uint8)
    for _ in range(int(rng.integers(8, 11))):
        r, c = rng.uniform(4, SIZE - 4, size=2)
        radius = rng.uniform(4, 9)
        gap = rng.uniform(0.5, 1.4) if rng.random() < 0.8 else 0.0
        width = rng.choice([1.0, 1.6, 2.2], p=[0.2, 0.4, 0.4])
        grid[_ring(rng, r, c, radius, width, gap)] = 1
    for _ in range(int(rng.integers(3, 6))):
        r, c = rng.uniform(0, SIZE, size=2)
        grid[_disc(r, c, rng.uniform(1.5, 3.5))] = 1
    return grid


def _arcs(rng: np.random.Generator) -> Grid:
    grid = np.zeros((SIZE, SIZE), dtype=np.uint8)
    for _ in range(int(rng.integers(9, 13))):
        r, c = rng.uniform(3, SIZE - 3, size=2)
        gap = rng.uniform(np.pi / 2, np.pi)
        grid[
            _ring(rng, r, c, rng.uniform(4, 9), rng.choice([1.0, 1.6, 2.2], p=[0.1, 0.6, 0.3]), gap)
        ] = 1
    return grid


def _blocks(rng: np.random.Generator) -> Grid:
    grid = np.zeros((SIZE, SIZE), dtype=np.uint8)
    top = int(rng.integers(4, 7))
    while top + 10 <= SIZE - 3:
        height = int(rng.integers(9, 13))
        left = int(rng.integers(2, 5))
        while left + 9 <= SIZE - 2:
            width = int(rng.integers(9, min(14, SIZE - 1 - left)))
            bottom, right = min(top + height, SIZE - 2), left + width
            side = int(rng.integers(2, 4))
            grid[top:bottom, left:right] = 1
            grid[top + 2 : bottom - 1, left + side : right - side] = 0  # the hole
            mid = int(rng.integers(left + side, right - side - 1))
            grid[bottom - 1, mid : mid + int(rng.integers(2, 4))] = 0  # it opens downward
            gc = int(rng.integers(left + side, right - side - 1))
            grid[top, gc] = grid[top + 1, gc + 1] = 0  # the gate above: a diagonal gap
            left = right + int(rng.integers(1, 5))
        top += height + int(rng.integers(1, 5))
    return grid


def _sines(rng: np.random.Generator) -> Grid:
    grid = np.zeros((SIZE, SIZE), dtype=np.uint8)
    for _ in range(int(rng.integers(8, 11))):
        length = int(rng.integers(15, 34))
        t0 = int(rng.integers(0, SIZE - length))
        t = np.arange(t0, t0 + length)
        base = rng.uniform(4, SIZE - 4)
        period, phase = rng.uniform(12, 30), rng.uniform(0, 2 * np.pi)
        wave = base + rng.uniform(2, 5) * np.sin(2 * np.pi * t / period + phase)
        thick = int(rng.integers(1, 3))
        across = np.clip(np.rint(wave).astype(int), 0, SIZE - thick)
        upright = rng.random() < 0.5
        # Join consecutive samples, so a steep stretch stays one unbroken stroke.
        for along, a, b in zip(t[:-1], across[:-1], across[1:], strict=True):
            lo, hi = min(a, b), max(a, b) + thick
            if upright:
                grid[along, lo:hi] = 1
            else:
                grid[lo:hi, along] = 1
    return grid


def _bars(rng: np.random.Generator) -> Grid:
    grid = np.zeros((SIZE, SIZE), dtype=np.uint8)
    row = int(rng.integers(4, 7))
    while row <= SIZE - 6:
        thick = int(rng.integers(1, 3))
        widths = [int(rng.integers(2, 6))]
        widths += [int(w) for w in rng.integers(1, 4, size=int(rng.integers(1, 4)))]
        _band_with_openings(rng, grid, row, thick, widths)
        row += thick + int(rng.integers(4, 7))
    return grid


_GENERATORS: dict[int, Callable[[np.random.Generator], Grid]] = {
    1: _random_shapes,
    2: _circles,
    3: _arcs,
    4: _blocks,
    5: _sines,
    6: _bars,
}

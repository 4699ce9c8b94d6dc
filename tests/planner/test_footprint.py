"""Footprints: validation, and the collision table per heading bin checked against shapely's
exact point-in-polygon (tests/naive_shapes.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import planner
from planner.analysis.distance import squared_distances
from planner.footprint import MAX_VERTICES, footprint_cells, footprint_of
from planner.motion import Grid, footprint_clearance, poses_free
from tests import naive_shapes

RECT = [[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]]
ARROW = [[0.4, 0.0], [0.0, 0.3], [-0.3, 0.3], [-0.1, 0.0], [-0.3, -0.3], [0.0, -0.3]]


@pytest.mark.parametrize(
    ("value", "field", "words"),
    [
        ([[0, 0], [1, 1], [1, 0], [0, 1]], "footprint", "crosses itself"),
        ([[-1, 0], [0, 0], [1, 0]], "footprint", "degenerate"),
        ([[0.1, 0.1]] * 2, "footprint", "3 to 32"),
        ([[math.cos(a), math.sin(a)] for a in np.linspace(0, 6, 33)], "footprint", "33 vertices"),
        ([[0.3, 0.2], [0.3, float("nan")], [-0.3, 0.0]], "footprint[1]", "finite"),
        ([[1, 1], [2, 1], [2, 2], [1, 2]], "footprint", "reference point"),
        ([[0.3, 0.2], [0.3, -0.2], "x"], "footprint[2]", "[x, y]"),
    ],
)
def test_bad_footprints_are_refused_naming_the_field(value: object, field: str, words: str) -> None:
    with pytest.raises(planner.InvalidInput, match=re_escape(words)) as info:
        planner.resolve_params("wide", footprint=value)
    assert info.value.field == field


def re_escape(text: str) -> str:
    import re

    return re.escape(text)


def test_a_footprint_sets_the_inscribed_radius_and_refuses_another() -> None:
    p = planner.resolve_params("wide", footprint=RECT)
    assert p.robot_radius == pytest.approx(0.2)
    assert p.footprint is not None
    assert sorted(p.footprint) == sorted((x, y) for x, y in RECT)
    assert planner.resolve_params("wide", **p.as_dict()).footprint == p.footprint
    with pytest.raises(planner.InvalidInput) as info:
        planner.resolve_params("wide", footprint=RECT, robot_radius=0.3)
    assert info.value.field == "robot_radius"


def test_footprints_are_kept_counter_clockwise() -> None:
    clockwise = footprint_of(RECT)  # RECT runs clockwise
    assert clockwise.vertices == tuple((float(x), float(y)) for x, y in RECT[::-1])
    assert footprint_of(RECT[::-1]).vertices == clockwise.vertices
    assert clockwise.polygon.exterior.is_ccw
    assert len(footprint_of([[math.cos(a), math.sin(a)] for a in np.arange(MAX_VERTICES)
                             * 2 * math.pi / MAX_VERTICES]).vertices) == MAX_VERTICES  # fmt: skip


def _random_grid(seed: int, shape: tuple[int, int], res: float) -> Grid:
    rng = np.random.default_rng(seed)
    blocked = (rng.random(shape) < 0.004).astype(np.uint8)
    blocked[20:24, 10:50] = 1
    dist = np.sqrt(squared_distances(blocked == 0, outside_blocked=True))
    frame = planner.MapFrame(shape, res, (1.0, -2.0, 0.3))
    return Grid(blocked, dist.astype(np.float32), True, frame)


@pytest.mark.parametrize(("vertices", "res"), [(RECT, 0.05), (ARROW, 0.05), (RECT, 0.1)])
def test_the_table_never_misses_a_blocked_center(vertices: list[list[float]], res: float) -> None:
    grid = _random_grid(1, (50, 70), res)
    fp = footprint_of(vertices)
    cells = footprint_cells(fp, res)
    rng = np.random.default_rng(2)
    H, W = grid.blocked.shape
    margin = fp.circumscribed_radius / res + 1
    uvt = np.stack(
        [rng.uniform(margin, W - margin, 3000), rng.uniform(margin, H - margin, 3000),
         rng.uniform(-7, 7, 3000)], axis=1,
    )  # fmt: skip
    free = poses_free(grid, cells, uvt)
    poses = grid.to_map(uvt)
    rows, cols = np.nonzero(grid.blocked)
    centers = grid.frame.centers(np.stack([rows, cols], axis=1))
    exact = np.array([not naive_shapes.hits(fp.vertices, centers, p) for p in poses])
    assert not (free & ~exact).any()  # free by the table: free exactly
    assert free.sum() >= 0.5 * exact.sum()  # and not far too cautious


def test_the_outline_clearance_is_within_a_cell_of_the_exact_one() -> None:
    import shapely

    grid = _random_grid(3, (50, 70), 0.05)
    fp = footprint_of(RECT)
    cells = footprint_cells(fp, 0.05)
    rng = np.random.default_rng(4)
    # Far from the map's edge, which counts as blocked here but not in the reference.
    uvt = np.stack([rng.uniform(20, 50, 300), rng.uniform(18, 32, 300), rng.uniform(-4, 4, 300)], 1)
    got = footprint_clearance(grid, cells, uvt)
    rows, cols = np.nonzero(grid.blocked)
    points = shapely.MultiPoint(grid.frame.centers(np.stack([rows, cols], axis=1)))
    for pose, value in zip(grid.to_map(uvt), got, strict=True):
        placed = shapely.affinity.translate(
            shapely.affinity.rotate(fp.polygon, pose[2], (0, 0), use_radians=True), *pose[:2]
        )
        if placed.distance(points) == 0:
            continue  # a center inside: no clearance to compare
        # Read on the outline's cells at the bin's center heading, from the pose's cell's center:
        # off by the cell's half diagonal twice and the far corner's turn over half a bin.
        bound = 0.05 * math.sqrt(2) + fp.circumscribed_radius * math.pi / 72 + 1e-6
        assert abs(value - placed.exterior.distance(points)) <= bound

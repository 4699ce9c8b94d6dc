"""Zones in the planner: polygons' cells and points against the naive even-odd test, the
simplicity check against exact pair-by-pair arithmetic, zoned maps (cells, ids, zones kept),
keepout masks, speed caps, and every refusal naming its field."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import planner
from planner import InvalidInput
from planner.maps.polygons import check_polygon, points_in_polygon, polygon_cells
from tests import naive


def star(rng: np.random.Generator, n: int, cx: float, cy: float, size: float) -> list[Any]:
    """A random star-shaped polygon around (cx, cy): simple, often concave."""
    angles = np.sort(rng.uniform(0, 2 * math.pi, n))
    radii = rng.uniform(0.2, 1.0, n) * size
    return [
        (cx + r * math.cos(a), cy + r * math.sin(a)) for a, r in zip(angles, radii, strict=True)
    ]


@given(
    st.integers(0, 2**32 - 1),
    st.integers(1, 14),
    st.integers(1, 14),
    st.integers(3, 12),
    st.sampled_from([0.0, 0.3, -2.0]),
)
def test_polygon_cells_against_naive(seed: int, H: int, W: int, n: int, yaw: float) -> None:
    rng = np.random.default_rng(seed)
    res = float(rng.choice([0.05, 0.1, 1.0]))
    origin = (float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), yaw)
    frame = planner.MapFrame((H, W), res, origin)
    centers = frame.centers([[rng.integers(H), rng.integers(W)]])[0]
    polygon = star(rng, n, float(centers[0]), float(centers[1]), res * max(H, W) * 0.7)
    if len(set(polygon)) < n:
        return
    expected = naive.polygon_cells((H, W), res, origin, polygon)
    np.testing.assert_array_equal(polygon_cells(frame, tuple(polygon)), expected)
    points = rng.uniform(-3, 3, size=(20, 2)) + centers
    inside = [naive.in_polygon(x, y, polygon) for x, y in points]
    assert points_in_polygon(points, tuple(polygon)).tolist() == inside


def test_polygon_cells_on_a_big_map_hold_the_area() -> None:
    """A 30 m x 20 m rectangle on a 0.05 m map holds 600 x 400 centers; a rotated one about as
    many (within its perimeter's cells)."""
    frame = planner.MapFrame((1000, 1000), 0.05)
    rect = ((1.0, 1.0), (31.0, 1.0), (31.0, 21.0), (1.0, 21.0))
    assert int(polygon_cells(frame, rect).sum()) == 600 * 400
    a = math.radians(30)
    rot = tuple(
        (25 + x * math.cos(a) - y * math.sin(a), 25 + x * math.sin(a) + y * math.cos(a))
        for x, y in ((-15, -10), (15, -10), (15, 10), (-15, 10))
    )
    assert abs(int(polygon_cells(frame, rot).sum()) - 240000) < 2 * (600 + 400) * 2


@given(st.integers(0, 2**32 - 1), st.integers(3, 9))
def test_simplicity_against_exact_pairs(seed: int, n: int) -> None:
    """Random polygons on a small integer lattice (many touching and collinear edges)."""
    rng = np.random.default_rng(seed)
    points = [(float(x), float(y)) for x, y in rng.integers(0, 4, size=(n, 2))]
    if any(points[i] == points[i - 1] for i in range(n)):
        return
    area = sum(points[i - 1][0] * points[i][1] - points[i][0] * points[i - 1][1] for i in range(n))
    if naive.simple(points) and area != 0:
        assert check_polygon(points, field="keepout[0]") == tuple(points)
    else:
        with pytest.raises(InvalidInput, match="intersects itself") as info:
            check_polygon(points, field="keepout[0]")
        assert info.value.field == "keepout[0]"


@pytest.mark.parametrize(
    ("points", "field", "words"),
    [
        ([(0, 0), (1, 0)], "keepout[0]", "3 to 1000 points; got 2"),
        ([(0, 0), (1, 0), (math.nan, 1)], "keepout[0][2]", "finite"),
        ([(0, 0), (1, 0), (math.inf, 1)], "keepout[0][2]", "finite"),
        ([(0, 0), (1, 0), (1e12, 1)], "keepout[0][2]", "at most"),
        ([(0, 0), (1, 1), (1, 0), (0, 1)], "keepout[0]", "intersects itself"),
        ([(0, 0), (2, 0), (1, 0)], "keepout[0]", "intersects itself"),
        ([(0, 0), (1, 0), (1, 0), (0, 1)], "keepout[0][2]", "repeats point 1"),
        ([(0, 0), (2, 0), (2, 2), (1, 0)], "keepout[0]", "intersects itself"),
        (
            [(0, 0), (4, 0), (4, 2), (2, 0), (0, 2)],
            "keepout[0]",
            "edge 0 (points 0, 1) meets edge 2",
        ),
        ([{"x": 0, "y": 0}, {"x": 1, "y": 0}, {"x": 1, "z": 1}], "keepout[0][2]", "{x, y}"),
        ([(0, 0), (1, 0), (True, 1)], "keepout[0][2]", "finite"),
        ("abc", "keepout[0]", "list of points"),
    ],
)
def test_bad_polygons_name_their_field(points: Any, field: str, words: str) -> None:
    with pytest.raises(InvalidInput, match=re_escape(words)) as info:
        check_polygon(points, field="keepout[0]")
    assert info.value.field == field


def re_escape(text: str) -> str:
    import re

    return re.escape(text)


def test_bad_speed_zones_name_their_field() -> None:
    base = planner.grid_map([[0] * 4] * 4, resolution=0.5)
    tri = [(0.1, 0.1), (1.9, 0.1), (1.0, 1.9)]
    for zone, field in [
        ({"polygon": tri, "max_speed": 0}, "speed[0].max_speed"),
        ({"polygon": tri, "max_speed": math.nan}, "speed[0].max_speed"),
        ({"polygon": tri, "max_speed": True}, "speed[0].max_speed"),
        ({"polygon": tri}, "speed[0].max_speed"),
        ({"polygon": tri, "max_speed": 1, "speeed": 2}, "speed[0].speeed"),
        ({"polygon": tri[:2], "max_speed": 1}, "speed[0].polygon"),
    ]:
        with pytest.raises(InvalidInput) as info:
            planner.zone_map(base, speed=[zone])
        assert info.value.field == field, zone
    with pytest.raises(InvalidInput, match="holds no cell") as info:
        planner.zone_map(base, keepout=[tri, [(10, 10), (11, 10), (11, 11)]])
    assert info.value.field == "keepout[1]"


def test_zoned_map_blocks_keepout_and_keeps_its_zones() -> None:
    grid = np.zeros((20, 30), dtype=np.int64)
    grid[5, :] = 1
    grid[15, 3] = -1
    base = planner.grid_map(grid, resolution=0.1, origin=(1.0, 2.0, 0.0))
    keepout = [(1.5, 2.5), (2.5, 2.5), (2.5, 3.5), (1.5, 3.5)]
    speed = [{"polygon": [(3.0, 2.0), (4.0, 2.0), (4.0, 4.0)], "max_speed": 0.25}]
    zoned = planner.zone_map(base, keepout=[keepout], speed=speed)
    cells = naive.polygon_cells(base.shape, 0.1, base.origin, keepout)
    assert cells.sum() == 100
    expected = np.where(cells, 100, base.occupancy)
    np.testing.assert_array_equal(zoned.occupancy, expected)
    assert base.occupancy.max() == 100
    assert int((base.occupancy == 100).sum()) == 30
    assert zoned.frame == base.frame
    assert zoned.zones is not None
    assert zoned.zones.base_map_id == base.map_id
    assert zoned.zones.keepout == (tuple(keepout),)
    assert zoned.zones.speed == (planner.SpeedZone(((3.0, 2.0), (4.0, 2.0), (4.0, 4.0)), 0.25),)
    # The id: the same zones on the same base give the same id; other zones another.
    again = planner.zone_map(base, keepout=[keepout], speed=speed)
    assert again.map_id == zoned.map_id
    other = planner.zone_map(base, keepout=[keepout], speed=[{**speed[0], "max_speed": 0.3}])
    assert other.map_id not in (zoned.map_id, base.map_id)
    # Speed zones alone: the cells are the base's, the id is not.
    slow = planner.zone_map(base, speed=speed)
    np.testing.assert_array_equal(slow.occupancy, base.occupancy)
    assert slow.map_id != base.map_id
    # Zoning a zoned map adds to its zones.
    twice = planner.zone_map(zoned, keepout=[[(3.0, 3.0), (3.5, 3.0), (3.5, 3.5)]])
    assert twice.zones is not None
    assert twice.zones.base_map_id == zoned.map_id
    assert len(twice.zones.keepout) == 2
    assert len(twice.zones.speed) == 1
    assert planner.Zones.from_dict(twice.zones.as_dict()) == twice.zones


def test_a_plain_grid_zoned_keeps_a_distinct_id() -> None:
    base = planner.grid_map([[0, 0, 0], [0, 0, 0], [0, 0, 0]])
    zoned = planner.zone_map(base, keepout=[[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]])
    fresh = planner.grid_map([[0, 0, 0], [0, 0, 0], [1, 0, 0]])
    np.testing.assert_array_equal(zoned.occupancy, fresh.occupancy)
    assert zoned.map_id != fresh.map_id


def test_keepout_mask_must_match_the_frame() -> None:
    base = planner.grid_map([[0] * 5] * 4, resolution=0.1, origin=(1.0, 2.0, 0.0))
    mask = planner.grid_map(
        [[0] * 5] * 3 + [[1, 1, 0, 0, 0]], resolution=0.1, origin=(1.0, 2.0, 0.0)
    )
    bits = planner.keepout_mask(mask, base.frame)
    zoned = planner.zone_map(base, mask=bits)
    assert (zoned.occupancy == 100).sum() == 2
    assert zoned.occupancy[3, :2].tolist() == [100, 100]
    assert zoned.zones is not None
    assert zoned.zones.keepout_masks[0].cells == 2
    for other, field in [
        (planner.grid_map([[0] * 5] * 3, resolution=0.1, origin=(1.0, 2.0, 0.0)), "image"),
        (
            planner.grid_map([[0] * 5] * 4, resolution=0.05, origin=(1.0, 2.0, 0.0)),
            "yaml.resolution",
        ),
        (planner.grid_map([[0] * 5] * 4, resolution=0.1, origin=(1.0, 2.5, 0.0)), "yaml.origin"),
        (planner.grid_map([[0] * 5] * 4, resolution=0.1, origin=(1.0, 2.0, 0.1)), "yaml.origin"),
    ]:
        with pytest.raises(InvalidInput) as info:
            planner.keepout_mask(other, base.frame)
        assert info.value.field == field


def test_speed_limits_take_the_least_cap() -> None:
    zones = planner.Zones(
        base_map_id="x",
        speed=(
            planner.SpeedZone(((0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)), 0.5),
            planner.SpeedZone(((1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)), 0.2),
        ),
    )
    caps = planner.speed_limits(zones, [[0.5, 0.5], [1.5, 1.5], [2.5, 2.5], [5.0, 5.0]])
    assert caps.tolist() == [0.5, 0.2, 0.2, math.inf]
    assert planner.speed_limits(None, [[0.5, 0.5]]).tolist() == [math.inf]


def assert_same_analysis(derived: planner.Analysis, fresh: planner.Analysis) -> None:
    assert derived.cspace is not None
    assert fresh.cspace is not None
    for name in ("blocked", "distance", "traversable", "unknown_cells"):
        np.testing.assert_array_equal(
            getattr(derived.cspace, name), getattr(fresh.cspace, name), err_msg=name
        )
    np.testing.assert_array_equal(derived.state, fresh.state)
    np.testing.assert_array_equal(derived.clean, fresh.clean)
    assert (derived.gates, derived.tunnels) == (fresh.gates, fresh.tunnels)
    assert derived.params_key == fresh.params_key
    assert derived.plain == fresh.plain
    assert derived.zones == fresh.zones


@given(
    st.integers(0, 2**32 - 1),
    st.integers(3, 40),
    st.integers(3, 40),
    st.sampled_from(["wide", "wfs-mmas", "mmas", "shortest"]),
    st.sampled_from([0.0, 0.1, 0.25]),
    st.sampled_from(["blocked", "free"]),
    st.integers(1, 3),
)
def test_rezoned_analysis_is_the_fresh_one(
    seed: int, H: int, W: int, preset: str, radius: float, unknown: str, zones: int
) -> None:
    """The analysis derived from the base's equals the zoned map's own, array for array, for
    every preset, radius and unknown policy, with zones anywhere (edges, corners, over walls)."""
    rng = np.random.default_rng(seed)
    grid = rng.choice([0, 0, 0, 0, 0, 0, 1, -1], size=(H, W))
    if rng.random() < 0.3:
        grid[:] = 0  # nothing blocked: the distance is infinite until the zone
    res = 0.1
    base = planner.grid_map(grid, resolution=res, origin=(-1.0, 0.5, 0.0))
    keepout = []
    for _ in range(zones):
        x0 = -1.0 + rng.uniform(-0.2, W * res)
        y0 = 0.5 + rng.uniform(-0.2, H * res)
        w, h = rng.uniform(0.05, 0.8, size=2)
        keepout.append([(x0, y0), (x0 + w, y0), (x0 + w, y0 + h), (x0, y0 + h)])
    try:
        zoned = planner.zone_map(base, keepout=keepout)
    except InvalidInput:
        return  # a zone between cell centers
    params = planner.resolve_params(preset, robot_radius=radius, unknown=unknown)
    derived = planner.rezone_analysis(planner.analyse_map(base, params), zoned, params)
    assert derived is not None
    assert_same_analysis(derived[0], planner.analyse_map(zoned, params))


def test_rezoned_analysis_on_depot_reuses_and_matches(ros: Any) -> None:
    base = planner.read_ros_map(ros / "depot.yaml")
    # Among the racks (a small window) and in the open hall (the window grows).
    for zone in (
        [(29.0, 7.0), (31.0, 7.0), (31.0, 9.0), (29.0, 9.0)],
        [(13.0, 3.0), (17.0, 3.0), (17.0, 12.0), (13.0, 12.0)],
    ):
        zoned = planner.zone_map(base, keepout=[zone])
        for params in (
            planner.resolve_params("wide", robot_radius=0.22),
            planner.resolve_params("wfs-mmas", robot_radius=0.22, unknown="free"),
        ):
            derived = planner.rezone_analysis(planner.analyse_map(base, params), zoned, params)
            assert derived is not None
            analysis, window = derived
            assert window.cells < base.shape[0] * base.shape[1]
            assert_same_analysis(analysis, planner.analyse_map(zoned, params))


def test_rezoning_refuses_what_it_cannot_derive() -> None:
    base = planner.grid_map([[0, 0, 0], [0, 1, 0], [0, 0, 0]], resolution=0.5)
    zoned = planner.zone_map(base, speed=[{"polygon": [(0, 0), (1, 0), (1, 1)], "max_speed": 1}])
    wide = planner.resolve_params("wide", robot_radius=0.1)
    a = planner.analyse_map(base, wide)
    other = planner.resolve_params("wide", robot_radius=0.2)
    assert planner.rezone_analysis(a, zoned, other) is None  # another key
    unblocked = planner.grid_map([[0, 0, 0], [0, 0, 0], [0, 0, 0]], resolution=0.5)
    assert planner.rezone_analysis(a, unblocked, wide) is None  # a blocked cell freed
    same = planner.rezone_analysis(a, zoned, wide)
    assert same is not None
    assert_same_analysis(same[0], planner.analyse_map(zoned, wide))


def test_pictures_hatch_keepout_and_label_speed_zones() -> None:
    from planner.render import draw
    from planner.render_zones import ZONE_COLOURS

    base = planner.grid_map([[0] * 30] * 20, resolution=0.5)
    zoned = planner.zone_map(
        base,
        keepout=[[(1.0, 1.0), (4.0, 1.0), (4.0, 4.0), (1.0, 4.0)]],
        speed=[{"polygon": [(8.0, 1.0), (14.0, 1.0), (14.0, 9.0), (8.0, 9.0)], "max_speed": 0.3}],
    )
    cell = 8
    image = np.asarray(draw(planner.analyse_map(zoned), cell=cell, legend=False))
    plain = np.asarray(draw(planner.analyse_map(base), cell=cell, legend=False))
    # The keepout square: cells (rows 12..17, cols 2..7), only its two colours inside.
    inside = image[13 * cell : 17 * cell, 3 * cell : 7 * cell].reshape(-1, 3)
    colours = {tuple(int(v) for v in p) for p in inside}
    assert colours == {ZONE_COLOURS["keepout"], ZONE_COLOURS["keepout_ground"]}
    # The speed zone: tinted amber, and a label in dark text at its middle.
    corner = image[12 * cell + 2, 17 * cell + 2]
    assert tuple(int(v) for v in corner) not in (
        (255, 255, 255),
        tuple(plain[12 * cell + 2, 17 * cell + 2]),
    )
    middle = image[10 * cell - 6 : 10 * cell + 6, 20 * cell : 24 * cell]
    assert (middle.sum(axis=2) < 200).any()  # the label's text
    # Outside the zones the picture is the unzoned map's.
    np.testing.assert_array_equal(image[:, 29 * cell :], plain[:, 29 * cell :])
    legend = draw(planner.analyse_map(zoned), cell=cell)
    assert legend.height > image.shape[0]


def test_a_map_holds_at_most_ten_thousand_points() -> None:
    base = planner.grid_map([[0] * 4] * 4, resolution=0.5)
    ring = [
        (1 + math.cos(2 * math.pi * k / 1000), 1 + math.sin(2 * math.pi * k / 1000))
        for k in range(1000)
    ]
    with pytest.raises(InvalidInput, match="at most 10000 points in all") as info:
        planner.zone_map(base, keepout=[ring] * 6, speed=[{"polygon": ring, "max_speed": 1}] * 5)
    assert info.value.field == "speed[4].polygon"  # the first polygon beyond
    zoned = planner.zone_map(
        base, keepout=[ring] * 5, speed=[{"polygon": ring, "max_speed": 1}] * 5
    )
    assert zoned.zones is not None
    assert len(zoned.zones.keepout) == 5
    with pytest.raises(InvalidInput, match="it has 10000 and the request adds 3") as info:
        planner.zone_map(zoned, keepout=[ring[::400]])  # its base's points count
    assert info.value.field == "keepout[0]"


def test_polygons_sharing_an_edge_through_centers_never_share_a_cell() -> None:
    """Edges through cell centers (x 2.5, y 2.5 on a 1 m map): each center on the shared edges
    falls in exactly one of the polygons, the scanline fill agreeing with the crossing test."""
    frame = planner.MapFrame((6, 6), 1.0)
    left = ((0.5, 0.5), (2.5, 0.5), (2.5, 5.5), (0.5, 5.5))
    right = ((2.5, 0.5), (4.5, 0.5), (4.5, 2.5), (2.5, 2.5))
    top = ((2.5, 2.5), (4.5, 2.5), (4.5, 5.5), (2.5, 5.5))
    cells = [polygon_cells(frame, p) for p in (left, right, top)]
    assert int(np.sum(cells, axis=0).max()) == 1
    union = np.sum(cells, axis=0) == 1
    for p, mine in zip((left, right, top), cells, strict=True):
        np.testing.assert_array_equal(mine, naive.polygon_cells((6, 6), 1.0, (0, 0, 0), p))
    # Half-open: the left and bottom edges' centers in, the right and top edges' out.
    expected = np.zeros((6, 6), dtype=bool)
    expected[1:6, 0:4] = True
    np.testing.assert_array_equal(union, expected)


@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.15, 0.3]))
def test_plans_on_zoned_maps_keep_the_radius_from_keepout(seed: int, radius: float) -> None:
    """On random maps with a random keepout triangle, every plan (and every pose) keeps more
    than the robot's radius from every keepout cell's center, or there is no plan."""
    rng = np.random.default_rng(seed)
    H, W = 24, 30
    grid = (rng.random((H, W)) < 0.08).astype(int)
    base = planner.grid_map(grid, resolution=0.1)
    cx, cy = rng.uniform(0.5, 2.5), rng.uniform(0.5, 1.9)
    tri = [(cx + 0.6 * math.cos(a), cy + 0.6 * math.sin(a)) for a in rng.uniform(0, 6.28, 3)]
    try:
        zoned = planner.zone_map(base, keepout=[tri])
    except InvalidInput:
        return  # a degenerate triangle, or one between centers
    keep = polygon_cells(base.frame, tuple(tri)) & (grid == 0)
    where = np.argwhere(keep)
    if where.size == 0:
        return
    params = planner.resolve_params("wide", robot_radius=radius)
    analysis = planner.analyse_map(zoned, params)
    assert analysis.cspace is not None
    free = np.argwhere(analysis.cspace.traversable == 1)
    if len(free) < 2:
        return
    for _ in range(3):
        a, b = free[rng.integers(len(free), size=2)]
        try:
            plan = planner.plan(
                zoned, a.tolist(), b.tolist(), analysis=analysis, **params.as_dict()
            )
        except planner.NoValidPath:
            continue
        gap = np.hypot(*(plan.path[:, None, :] - where[None, :, :]).transpose(2, 0, 1))
        assert float(gap.min()) * 0.1 > radius
        centers = base.frame.centers(where)
        xy = plan.poses[:, :2]
        reach = np.hypot(*(xy[:, None, :] - centers[None, :, :]).transpose(2, 0, 1))
        assert float(reach.min()) > radius

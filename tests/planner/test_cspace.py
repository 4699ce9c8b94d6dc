"""Configuration space, the metric wall term and circle obstacles against brute force; plans in
meters on the ROS maps: clearance above the radius, legal moves, ``path_xy`` on the formula."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import planner
from planner import InvalidInput
from tests import naive

RADIUS = 0.22


@given(
    st.integers(0, 2**32 - 1),
    st.integers(1, 9),
    st.integers(1, 9),
    st.floats(0.0, 0.5),
    st.sampled_from(["blocked", "free"]),
)
def test_configuration_space_against_brute_force(
    seed: int, H: int, W: int, radius: float, unknown: str
) -> None:
    rng = np.random.default_rng(seed)
    grid = rng.choice([0, 0, 0, 1, -1], size=(H, W))
    robot_map = planner.grid_map(grid, resolution=0.1)
    cs = planner.configuration_space(robot_map, robot_radius=radius, unknown=unknown)  # type: ignore[arg-type]
    blocked = (grid == 1) | ((grid == -1) & (unknown == "blocked"))
    expected = naive.distances(blocked, outside_blocked=unknown == "blocked")
    np.testing.assert_allclose(cs.distance, expected, rtol=1e-6)
    traversable = ~blocked & (expected * 0.1 > radius + 1e-9)
    np.testing.assert_array_equal(cs.traversable == 1, traversable)
    np.testing.assert_array_equal(cs.blocked == 1, blocked)


def test_a_cell_exactly_at_the_radius_is_not_traversable() -> None:
    robot_map = planner.grid_map([[1, 0, 0, 0, 0, 0]], resolution=0.05)
    cs = planner.configuration_space(robot_map, robot_radius=0.1, unknown="free")
    assert cs.traversable.tolist() == [[0, 0, 0, 1, 1, 1]]


def test_wide_clean_decays_to_zero_at_the_distance() -> None:
    robot_map = planner.grid_map([[1] + [0] * 30], resolution=0.05)
    cs = planner.configuration_space(robot_map, robot_radius=0.2, unknown="free")
    clean = planner.wide_clean(cs, weight=4.0, wide_distance=0.5)
    from planner.analysis.cspace import WIDE_EXPONENT

    for c in range(31):
        s = c * 0.05 - 0.2
        if cs.traversable[0, c] == 0:
            assert clean[0, c] == 0
        else:
            want = 4.0 * max(0.0, 1 - s / 0.5) ** WIDE_EXPONENT
            assert clean[0, c] == pytest.approx(want, rel=1e-5, abs=1e-6)
    assert clean[0, 5] > clean[0, 8] > clean[0, 15] == 0.0


@given(
    st.floats(-1.0, 1.0),
    st.floats(-1.0, 1.0),
    st.floats(0.0, 0.4),
    st.floats(0.0, 0.3),
    st.floats(-math.pi, math.pi),
)
def test_circle_cells_against_brute_force(
    x: float, y: float, radius: float, robot_radius: float, yaw: float
) -> None:
    robot_map = planner.grid_map(np.zeros((12, 15)), resolution=0.1, origin=(-0.7, -0.5, yaw))
    middle = robot_map.frame.centers([[6, 7]])[0].tolist()  # in the map whatever the yaw
    circles = [{"x": x, "y": y, "radius": radius}, {"x": middle[0], "y": middle[1], "radius": 0.05}]
    # The circle's center in the map's own axes: a circle clear of the map is refused.
    u = math.cos(yaw) * (x + 0.7) + math.sin(yaw) * (y + 0.5)
    v = -math.sin(yaw) * (x + 0.7) + math.cos(yaw) * (y + 0.5)
    gap = math.hypot(max(-u, 0.0, u - 1.5), max(-v, 0.0, v - 1.2))
    if gap > radius + robot_radius:
        with pytest.raises(InvalidInput, match=r"dynamic_obstacles\[0\] .* entirely outside"):
            planner.circle_cells(robot_map, circles, robot_radius=robot_radius)
        return
    got = planner.circle_cells(robot_map, circles, robot_radius=robot_radius)
    want = naive.circle_cells((12, 15), 0.1, (-0.7, -0.5, yaw), circles, robot_radius)
    assert {tuple(rc) for rc in got.tolist()} == want
    assert len(got) == len(want)


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.0])
def test_many_and_huge_circles_against_brute_force(yaw: float) -> None:
    """Radii from 0 to 10**6 m, centers in and far beyond the map: each row's run of cells,
    solved for and clipped to the map, is the brute force's."""
    rng = np.random.default_rng(7)
    robot_map = planner.grid_map(np.zeros((12, 15)), resolution=0.1, origin=(-0.7, -0.5, yaw))
    middle = robot_map.frame.centers([[6, 7]])[0]
    circles = []
    for radius in [0.0, 0.05, 0.13, 0.4, 0.75, 3.0, 1e3, 1e6]:
        for _ in range(4):
            cell = [rng.integers(0, 12), rng.integers(0, 15)]
            x, y = robot_map.frame.centers([cell])[0] + rng.uniform(-0.04, 0.04, 2)
            circles.append({"x": float(x), "y": float(y), "radius": radius})
    # Far away, reaching just into the map.
    far = 1e5
    circles.append({"x": float(middle[0] + far), "y": float(middle[1]), "radius": far - 0.3})
    for some in (circles[:8], circles[8:20], circles[-1:], circles):
        got = planner.circle_cells(robot_map, some, robot_radius=0.02)
        want = naive.circle_cells((12, 15), 0.1, (-0.7, -0.5, yaw), some, 0.02)
        assert {tuple(rc) for rc in got.tolist()} == want
        assert len(got) == len(want)
        assert got.tolist() == sorted(got.tolist())


def test_circle_cells_cost_the_rows_not_the_radius() -> None:
    """2,000 circles of 10**6 m over a 2000 x 2000 map: every cell once (a box per circle
    would be 8 * 10**9 cells)."""
    robot_map = planner.grid_map(np.zeros((2000, 2000), dtype=np.int8), resolution=0.05)
    rng = np.random.default_rng(1)
    circles = [
        {"x": float(x), "y": float(y), "radius": 1e6} for x, y in rng.uniform(0, 100, (2000, 2))
    ]
    cells = planner.circle_cells(robot_map, circles)
    assert cells.shape == (4_000_000, 2)
    assert cells[-1].tolist() == [1999, 1999]


def test_bad_circles_and_radius() -> None:
    robot_map = planner.grid_map([[0]], resolution=0.1)
    with pytest.raises(InvalidInput) as info:
        planner.circle_cells(robot_map, [{"x": 0, "y": 0, "radius": -1}])
    assert info.value.field == "dynamic_obstacles[0].radius"
    with pytest.raises(InvalidInput, match="'x' and 'y'"):
        planner.circle_cells(robot_map, [{"radius": 1}])
    with pytest.raises(InvalidInput, match="robot_radius must be in"):
        planner.resolve_params("wide", robot_radius=-0.1)
    with pytest.raises(InvalidInput, match="unknown must be"):
        planner.resolve_params("wide", unknown="maybe")


# Plans in meters


def legal_step(traversable: np.ndarray, a: list[int], b: list[int]) -> bool:
    dr, dc = b[0] - a[0], b[1] - a[1]
    if max(abs(dr), abs(dc)) != 1 or not traversable[b[0], b[1]]:
        return False
    return not (dr and dc) or bool(traversable[a[0], b[1]] and traversable[b[0], a[1]])


def clearance_brute_force(blocked: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Distance from each cell to the nearest blocked cell or cell just outside the map."""
    H, W = blocked.shape
    sources = np.argwhere(blocked)
    ring = [(r, -1) for r in range(-1, H + 1)] + [(r, W) for r in range(-1, H + 1)]
    ring += [(-1, c) for c in range(W)] + [(H, c) for c in range(W)]
    sources = np.concatenate([sources, np.array(ring)])
    out = np.empty(len(cells))
    for i, (r, c) in enumerate(cells):
        out[i] = np.sqrt(((sources - [r, c]) ** 2).sum(axis=1).min())
    return out


@pytest.mark.parametrize("name", ["depot", "tb3_sandbox", "smoothers_world"])
def test_plans_keep_the_robot_clear_on_the_ros_maps(ros: Path, name: str) -> None:
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    p = planner.resolve_params("wide", robot_radius=RADIUS)
    analysis = planner.analyse_map(robot_map, p)
    blocked = (robot_map.occupancy >= 65) | (robot_map.occupancy < 0)
    traversable = analysis.cspace.traversable if analysis.cspace is not None else None
    assert traversable is not None
    rng = np.random.default_rng(sum(map(ord, name)))
    cells = np.argwhere(analysis.passable() == 1)
    planned = 0
    while planned < 20:
        s, g = cells[rng.integers(len(cells), size=2)]
        if math.hypot(*(s - g)) < 40:
            continue
        start = dict(zip("xy", robot_map.frame.centers([s])[0].tolist(), strict=True))
        try:
            plan = planner.plan(
                robot_map, start, g.tolist(), analysis=analysis, robot_radius=RADIUS
            )
        except planner.NoValidPath:
            continue
        planned += 1
        path = plan.path
        assert path[0].tolist() == s.tolist()
        assert path[-1].tolist() == g.tolist()
        clearance_m = clearance_brute_force(blocked, path) * robot_map.resolution
        assert (clearance_m > RADIUS).all()
        assert plan.min_clearance_m == pytest.approx(clearance_m.min(), rel=1e-5)
        assert plan.mean_clearance_m == pytest.approx(clearance_m.mean(), rel=1e-5)
        assert all(
            legal_step(traversable, a, b)
            for a, b in zip(path[:-1].tolist(), path[1:].tolist(), strict=True)
        )
        xy = [
            naive.cell_center(robot_map.shape, robot_map.resolution, robot_map.origin, r, c)
            for r, c in path.tolist()
        ]
        np.testing.assert_allclose(plan.path_xy, xy, atol=1e-9)
        steps = np.hypot(*np.diff(np.array(xy), axis=0).T)
        assert plan.length_m == pytest.approx(steps.sum())
        summary = plan.summary()
        assert summary["path_xy"][0] == pytest.approx(list(xy[0]))
        assert {"length_m", "min_clearance_m", "mean_clearance_m", "path", "length"} <= set(summary)


def test_a_plain_grid_plans_as_before() -> None:
    grid = planner.environment(4, seed=0)
    for preset in planner.PRESETS:
        old = planner.plan(grid, (3, 6), (47, 14), preset=preset)
        new = planner.plan(planner.grid_map(grid), (3, 6), (47, 14), preset=preset)
        assert new.analysis.wall_cost == "cells"
        np.testing.assert_array_equal(old.analysis.state, new.analysis.state)
        np.testing.assert_array_equal(old.analysis.clean, new.analysis.clean)
        np.testing.assert_array_equal(old.path, new.path)
        assert old.min_clearance == new.min_clearance
        assert new.summary()["path_xy"][0] == [6.5, 50 - 1 - 3 + 0.5]


def test_analysis_keys_tell_analyses_apart() -> None:
    plain = planner.grid_map(np.zeros((5, 5)))
    framed = planner.grid_map(np.zeros((5, 5)), resolution=0.1)
    wide = planner.resolve_params("wide")
    keys = {
        planner.analysis_key(plain, wide),
        planner.analysis_key(plain, planner.resolve_params("wide", robot_radius=0.5)),
        planner.analysis_key(plain, planner.resolve_params("wide", unknown="free")),
        planner.analysis_key(framed, wide),
        planner.analysis_key(framed, planner.resolve_params("wide", occupied_threshold=50)),
        planner.analysis_key(framed, planner.resolve_params("wide", wide_distance=0.3)),
    }
    assert len(keys) == 6
    # Parameters the analysis does not use do not split the cache.
    assert planner.analysis_key(plain, wide) == planner.analysis_key(
        plain, planner.resolve_params("wide", alpha=5, occupied_threshold=50)
    )
    analysis = planner.analyse_map(framed, planner.resolve_params("wide", robot_radius=0.1))
    with pytest.raises(InvalidInput, match="other parameters"):
        planner.plan(None, (2, 2), (0, 0), analysis=analysis)


def test_unknown_space_blocked_or_free() -> None:
    grid = np.array([[0, -1, -1, 0]] * 3)
    robot_map = planner.grid_map(grid, resolution=0.1)
    with pytest.raises(planner.NoValidPath):
        planner.plan(robot_map, (1, 0), (1, 3))
    p = planner.plan(robot_map, (1, 0), (1, 3), unknown="free")
    assert p.path[-1].tolist() == [1, 3]
    # Outside the map counts as unknown: free, a corridor one cell wide is no tight tunnel.
    corridor = planner.grid_map(np.zeros((1, 6)), resolution=0.1)
    assert planner.analyse_map(corridor, planner.resolve_params("wide")).tunnels == 6
    assert (
        planner.analyse_map(corridor, planner.resolve_params("wide", unknown="free")).tunnels == 0
    )


def test_start_and_goal_in_the_margin_are_named(ros: Path) -> None:
    robot_map = planner.read_ros_map(ros / "smoothers_world.yaml")
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=RADIUS))
    assert analysis.cspace is not None
    margin = np.argwhere(analysis.cspace.margin)[0]
    x, y = robot_map.frame.centers([margin])[0]
    with pytest.raises(InvalidInput, match="START_OCCUPIED") as info:
        planner.plan(
            robot_map, {"x": x, "y": y}, (150, 150), analysis=analysis, robot_radius=RADIUS
        )
    assert info.value.field == "start"
    assert "robot_radius 0.22 m" in str(info.value)
    with pytest.raises(InvalidInput, match="outside the map"):
        planner.plan(
            robot_map, {"x": -3.0, "y": 1.0}, (150, 150), analysis=analysis, robot_radius=RADIUS
        )


def test_dynamic_margin_in_meters_becomes_cells_of_the_map() -> None:
    robot_map = planner.grid_map(np.zeros((20, 20), dtype=np.int8), resolution=0.05)
    p = planner.plan(robot_map, [0, 0], [19, 19], dynamic_margin_m=0.3)
    assert p.params.dynamic_margin == 6  # 0.3 m of 0.05 m cells
    assert (
        planner.plan(robot_map, [0, 0], [19, 19], dynamic_margin_m=0.26).params.dynamic_margin == 6
    )
    assert planner.plan(robot_map, [0, 0], [19, 19]).params.dynamic_margin == 1  # cells, unset
    # The margin holds while stepping: an obstacle 0.3 m away holds the robot up...
    assert planner.Session(p).step([[0, 6]]).move == "WAIT"
    # ...and one cell further it does not.
    assert planner.Session(p).step([[0, 8]]).move != "WAIT"
    with pytest.raises(planner.InvalidInput, match="dynamic_margin_m 1 is 20 cells"):
        planner.plan(robot_map, [0, 0], [19, 19], dynamic_margin_m=1.0)


def test_dynamic_margin_in_cells_and_in_meters_do_not_go_together() -> None:
    with pytest.raises(InvalidInput) as info:
        planner.resolve_params("wide", dynamic_margin=2, dynamic_margin_m=0.3)
    assert "dynamic_margin (cells) or dynamic_margin_m (meters), not both" in str(info.value)
    assert info.value.field == "params.dynamic_margin_m"
    # A preset's own dynamic_margin does not count, nor an unset dynamic_margin_m.
    assert planner.resolve_params("wide", dynamic_margin_m=0.3).dynamic_margin_m == 0.3
    assert (
        planner.resolve_params("wide", dynamic_margin=2, dynamic_margin_m=None).dynamic_margin == 2
    )


def test_a_circle_outside_the_map_is_refused() -> None:
    robot_map = planner.grid_map([[0, 0, 0], [0, 0, 0]], resolution=0.5, origin=[-1.0, 0.0, 0.0])
    with pytest.raises(InvalidInput) as info:
        planner.circle_cells(
            robot_map, [{"x": 0, "y": 0.5, "radius": 0.1}, {"x": 5.0, "y": 0.5, "radius": 0.2}]
        )
    assert info.value.field == "dynamic_obstacles[1]"
    message = str(info.value)
    assert "{'x': 5.0, 'y': 0.5, 'radius': 0.2} is entirely outside the map" in message
    assert "x [-1, 0.5], y [0, 1]" in message
    # Outside, but touching the map: kept, whether it blocks a cell or not.
    assert planner.circle_cells(robot_map, [{"x": 0.75, "y": 0.25, "radius": 0.3}]).size == 0
    near = planner.circle_cells(robot_map, [{"x": 0.75, "y": 0.25, "radius": 0.6}])
    assert near.tolist() == [[1, 2]]
    # The robot's radius widens a circle.
    point = [{"x": 1.0, "y": 0.25, "radius": 0.0}]
    assert planner.circle_cells(robot_map, point, robot_radius=0.8).tolist() == [[1, 2]]
    with pytest.raises(InvalidInput, match="entirely outside"):
        planner.circle_cells(robot_map, point, robot_radius=0.4)


def test_a_position_in_the_margin_is_named_as_start_and_goal_are() -> None:
    grid = np.zeros((10, 10), dtype=np.int8)
    grid[4, 4] = 1
    robot_map = planner.grid_map(grid, resolution=0.1)
    p = planner.plan(robot_map, [8, 1], [2, 7], robot_radius=0.15)
    margin = {"x": 0.52, "y": 0.58}  # cell [4, 5], 0.1 m from the obstacle
    with pytest.raises(InvalidInput) as info:
        planner.Session(p).step([], position=margin)
    assert info.value.field == "position"
    assert str(info.value) == (
        "POSITION_OCCUPIED: position {'x': 0.52, 'y': 0.58} (cell [4, 5]) is not traversable: "
        "its clearance 0.100 m is not more than robot_radius 0.15 m; the nearest free cell is "
        "[4, 6], the point {x: 0.650, y: 0.550}, 0.100 m away"
    )
    with pytest.raises(InvalidInput, match=r"POSITION_OCCUPIED: position \[4, 5\] is not"):
        planner.Session(p).step([], position=[4, 5])
    with pytest.raises(InvalidInput, match=r"position \[4, 4\] is on an obstacle"):
        planner.Session(p).step([], position=[4, 4])
    # A free point is the cell containing it.
    assert tuple(planner.Session(p).step([], position={"x": 0.25, "y": 0.25}).previous) == (7, 2)

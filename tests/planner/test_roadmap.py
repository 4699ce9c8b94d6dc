"""The fleet roadmap: separation (exact, over every pair of disjoint elements), collision-free
nodes and edges, coverage of narrow passages and of the shared ROS maps, route length against
the single-robot ``wide`` plan, edge costs, and the plain grid's 4-connected cells."""

from __future__ import annotations

import itertools
import statistics
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import planner
from planner.fleets.graph import Graph, grid_graph
from planner.fleets.roadmap import ATTACH_REACH, attach, attach_all, build_roadmap
from planner.fleets.roadmap_nodes import spacing
from planner.fleets.segments import segment_distance, supercover
from tests import naive_roadmap
from tests.conftest import ROS_MAP_NAMES

RADII = (0.15, 0.22, 0.3)


@cache
def _ros(folder: Path, name: str, radius: float) -> tuple[planner.Analysis, Graph]:
    robot_map = planner.read_ros_map(folder / f"{name}.yaml")
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=radius))
    return analysis, build_roadmap(analysis, radius=radius)


def _synthetic(rows: list[list[int]], radius: float) -> tuple[planner.Analysis, Graph]:
    m = planner.grid_map(rows, resolution=0.05)
    analysis = planner.analyse_map(m, planner.resolve_params("wide", robot_radius=radius))
    return analysis, build_roadmap(analysis, radius=radius)


def _rooms(corridor_m: float, *, length: int = 60, tilt: bool = False) -> list[list[int]]:
    """Two 60 x 60 cell rooms (3 m) joined by a corridor ``corridor_m`` wide (0.05 m cells),
    straight or with a step halfway."""
    width = round(corridor_m / 0.05)
    H, W = 60, 60 + length + 60
    grid = np.ones((H + 2, W + 2), dtype=np.uint8)
    grid[1:-1, 1:61] = 0
    grid[1:-1, W - 59 : W + 1] = 0
    top = H // 2 - width // 2
    for c in range(61, W - 59):
        shift = 6 if tilt and c > 61 + length // 2 else 0
        grid[1 + top + shift : 1 + top + shift + width, c] = 0
    return grid.tolist()


def _check_separation(graph: Graph) -> None:
    separation = 2 * graph.radius / graph.resolution
    assert naive_roadmap.too_close(graph, separation) == []


def _check_collision_free(graph: Graph, analysis: planner.Analysis) -> None:
    free = analysis.state != 1
    assert free[graph.cells[:, 0], graph.cells[:, 1]].all()
    for u, v in naive_roadmap.elements(graph)[graph.nodes :].tolist():
        a, b = tuple(graph.cells[u].tolist()), tuple(graph.cells[v].tolist())
        assert all(free[cell] for cell in naive_roadmap.supercover(a, b)), (a, b)


# The kernels against their slow references.


def test_supercover_is_the_exact_one() -> None:
    rng = np.random.default_rng(1)
    for _ in range(300):
        a, b = rng.integers(0, 12, size=2), rng.integers(0, 12, size=2)
        got = {tuple(cell) for cell in supercover(a, b).tolist()}
        assert got == naive_roadmap.supercover(tuple(a.tolist()), tuple(b.tolist())), (a, b)


def test_segment_distance_is_the_reference() -> None:
    rng = np.random.default_rng(2)
    ends = rng.integers(-6, 7, size=(400, 4, 2))
    for a, b, c, d in ends:
        want = naive_roadmap.segment_sq(a[None], b[None], c[None], d[None])[0]
        assert segment_distance(a, b, c, d) == pytest.approx(np.sqrt(want), abs=1e-9)


def test_the_separation_check_finds_crossing_edges() -> None:
    cells = np.array([[0, 0], [10, 10], [0, 10], [10, 0]])
    indptr = np.array([0, 1, 2, 3, 4])
    indices = np.array([1, 0, 3, 2])
    g = Graph(cells, indptr, indices, np.ones(4), (11, 11), radius=0.1, resolution=0.05)
    assert len(naive_roadmap.too_close(g, 4.0)) == 1  # the two diagonals cross
    assert naive_roadmap.too_close(g, 4.0)[0][-1] == 0.0


# 1 and 2: separation and collision-free, on the shared maps and synthetic ones.


@pytest.mark.parametrize("radius", RADII)
@pytest.mark.parametrize("name", ROS_MAP_NAMES)
def test_ros_roadmaps_keep_robots_apart_and_off_obstacles(
    ros: Path, name: str, radius: float
) -> None:
    analysis, graph = _ros(ros, name, radius)
    _check_separation(graph)
    _check_collision_free(graph, analysis)


@pytest.mark.parametrize("radius", [0.1, 0.22, 0.3])
@pytest.mark.parametrize("tilt", [False, True])
def test_synthetic_roadmaps_keep_robots_apart_and_off_obstacles(radius: float, tilt: bool) -> None:
    rows = _rooms(2 * radius + 0.3, tilt=tilt)
    rows[20][20] = rows[40][30] = 1  # pillars in a room
    analysis, graph = _synthetic(rows, radius)
    _check_separation(graph)
    _check_collision_free(graph, analysis)


# 3: coverage.


@pytest.mark.parametrize("radius", [0.15, 0.22, 0.3])
@pytest.mark.parametrize("extra", ["2r+0.05", "2r+0.3", "3r", "4r"])
def test_every_corridor_a_robot_fits_through_joins_the_rooms(radius: float, extra: str) -> None:
    width = {"2r+0.05": 2 * radius + 0.05, "2r+0.3": 2 * radius + 0.3}.get(extra)
    width = width if width is not None else float(extra[0]) * radius
    analysis, graph = _synthetic(_rooms(width), radius)
    left, right = attach_all(graph, analysis, [[31, 30], [31, 150]])
    assert left >= 0
    assert right >= 0
    labels = naive_roadmap.components(graph)
    assert labels[left] == labels[right], (radius, extra)
    # one lane: the corridor's nodes, in order along it, a chain of edges
    inside = np.flatnonzero((graph.cells[:, 1] > 75) & (graph.cells[:, 1] < 105))
    if width < 4 * radius + 1e-9:
        inside = inside[np.argsort(graph.cells[inside, 1])]
        assert len(inside) >= 1
        for u, v in itertools.pairwise(inside.tolist()):
            assert v in graph.neighbours(u), (u, v)
    _check_separation(graph)


def _turning(width_cells: int, turn: str, rotation: int, arm: int = 50) -> list[list[int]]:
    """A corridor ``width_cells`` wide turning a right angle (``"L"``) or two (``"U"``), its
    arms ``arm`` cells long, rotated ``rotation`` quarter turns."""
    grid = np.ones((arm + 4, arm + 4), dtype=np.uint8)
    grid[2 : 2 + width_cells, 2 : arm + 2] = 0
    grid[2 : arm + 2, arm + 2 - width_cells : arm + 2] = 0
    if turn == "U":
        grid[arm + 2 - width_cells : arm + 2, 2 : arm + 2] = 0
    rows: list[list[int]] = np.rot90(grid, rotation).tolist()
    return rows


@pytest.mark.parametrize("radius", [0.15, 0.3])
@pytest.mark.parametrize("extra", [0.05, 0.2, 0.4])
def test_a_corridor_turning_corners_is_one_lane_round_them(radius: float, extra: float) -> None:
    """Nodes either side of a corner would cut it (the medial axis rounds it off): a node on
    the corner itself sees down both arms. Every cell a robot's center fits on joins the
    roadmap, and the roadmap is one piece."""
    for turn, rotation in [("L", 0), ("L", 1), ("L", 2), ("L", 3), ("U", 0)]:
        rows = _turning(round((2 * radius + extra) / 0.05), turn, rotation)
        analysis, graph = _synthetic(rows, radius)
        joins = attach_all(graph, analysis, np.argwhere(analysis.state != 1))
        assert (joins >= 0).all(), (turn, rotation)
        assert len(set(naive_roadmap.components(graph)[joins].tolist())) == 1, (turn, rotation)
        _check_separation(graph)


def _pairs(analysis: planner.Analysis, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random pairs of two cells a single ``wide`` plan travels between: benchmarks/roadmap.py's."""
    from tests.scripts import load_benchmark

    bench = load_benchmark("roadmap")
    pairs: tuple[np.ndarray, np.ndarray] = bench.reachable_pairs(
        analysis, count, np.random.default_rng(seed)
    )
    return pairs


def _joins(
    graph: Graph, analysis: planner.Analysis, starts: np.ndarray, goals: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The nodes the starts and goals join, as a fleet's robots do: each goal its nearest node,
    each start the node that leads it there best."""
    g = attach_all(graph, analysis, goals)
    return attach_all(graph, analysis, starts, toward=g), g


@pytest.mark.parametrize("radius", [0.22, 0.3])
@pytest.mark.parametrize("name", ROS_MAP_NAMES)
def test_random_reachable_pairs_are_joined_through_the_roadmap(
    ros: Path, name: str, radius: float
) -> None:
    analysis, graph = _ros(ros, name, radius)
    starts, goals = _pairs(analysis, 200, seed=0)
    if len(starts) == 0:  # no two cells a robot of this radius may stand on (testmap, 0.3 m)
        assert graph.edges == 0
        return
    s, g = _joins(graph, analysis, starts, goals)
    labels = naive_roadmap.components(graph)
    joined = (s >= 0) & (g >= 0)
    joined[joined] &= labels[s[joined]] == labels[g[joined]]
    assert joined.mean() >= 0.99, joined.mean()


def test_the_pairs_are_the_ones_a_single_wide_plan_travels_between(ros: Path) -> None:
    """testmap at 0.22 m: four cells a robot's center fits on, three in a column and one
    diagonal to its end across a zero-width gap; a plan crosses no such gap."""
    analysis, _ = _ros(ros, "testmap", 0.22)
    robot_map = planner.read_ros_map(ros / "testmap.yaml")
    cells = {tuple(c) for c in np.argwhere(analysis.state != 1).tolist()}
    starts, goals = _pairs(analysis, 50, seed=3)
    drawn = {tuple(c) for c in np.concatenate([starts, goals]).tolist()}
    assert len(cells) == 4
    assert len(drawn) == 3
    lone = (cells - drawn).pop()
    with pytest.raises(planner.NoValidPath):
        planner.plan(
            robot_map, list(lone), list(drawn.pop()), analysis=analysis, preset="wide",
            robot_radius=0.22,
        )  # fmt: skip


# 4: route length.


@pytest.mark.parametrize("radius", [0.22, 0.3])
@pytest.mark.parametrize("name", ROS_MAP_NAMES)
def test_routes_are_at_most_a_tenth_longer_than_the_wide_plan(
    ros: Path, name: str, radius: float
) -> None:
    analysis, graph = _ros(ros, name, radius)
    robot_map = planner.read_ros_map(ros / f"{name}.yaml")
    starts, goals = _pairs(analysis, 30, seed=1)
    if len(starts) == 0:  # no route to take (testmap, 0.3 m)
        assert graph.edges == 0
        return
    s, g = _joins(graph, analysis, starts, goals)
    routes = naive_roadmap.route_lengths(graph, starts, goals, s, g) * robot_map.resolution
    ratios = []
    for k in range(len(starts)):
        plan = planner.plan(
            robot_map, starts[k].tolist(), goals[k].tolist(), analysis=analysis,
            preset="wide", robot_radius=radius,
        )  # fmt: skip
        ratios.append(routes[k] / plan.length_m)
    assert statistics.median(ratios) <= 1.10, ratios


# 5: costs.


def test_costs_are_the_length_or_the_length_and_the_clean_penalty(ros: Path) -> None:
    analysis, wide = _ros(ros, "smoothers_world", 0.22)
    plain = build_roadmap(analysis, radius=0.22, wide=False)
    np.testing.assert_array_equal(plain.indices, wide.indices)
    source = np.repeat(np.arange(wide.nodes), np.diff(wide.indptr))
    d = wide.cells[wide.indices] - wide.cells[source]
    length = np.hypot(d[:, 0], d[:, 1])
    np.testing.assert_allclose(plain.costs, length)
    penalty = []
    for u, v in zip(source.tolist(), wide.indices.tolist(), strict=True):
        (r0, c0), (r1, c1) = wide.cells[u], wide.cells[v]
        n = max(abs(r1 - r0), abs(c1 - c0))
        steps = [((r1 - r0) * k / n, (c1 - c0) * k / n) for k in range(1, n + 1)]
        penalty.append(sum(float(analysis.clean[r0 + round(r), c0 + round(c)]) for r, c in steps))
    np.testing.assert_allclose(wide.costs, length + np.array(penalty), rtol=1e-9)
    assert (wide.costs >= length).all()
    assert (wide.costs > length).any()


# 6: the plain grid.


def test_a_plain_grid_with_radius_zero_is_its_cells_4_connected(movingai: Path) -> None:
    grid = np.asarray(planner.read_map(movingai / "den312d.map"))
    analysis = planner.analyse(grid)
    graph = build_roadmap(analysis, radius=0.0, wide=False)
    expected = grid_graph(grid == 0)
    np.testing.assert_array_equal(graph.cells, expected.cells)
    np.testing.assert_array_equal(graph.indptr, expected.indptr)
    np.testing.assert_array_equal(graph.indices, expected.indices)
    np.testing.assert_array_equal(graph.costs, expected.costs)


def _pillars() -> list[list[int]]:
    """A 20 x 30 cell room with a pillar and a wall's stub."""
    grid = np.zeros((20, 30), dtype=np.uint8)
    grid[8:11, 10:13] = 1
    grid[0:6, 20] = 1
    return grid.tolist()


def test_a_robot_within_half_a_cell_gets_the_cells_4_connected_and_they_are_apart() -> None:
    analysis, graph = _synthetic(_pillars(), 0.025)  # 2r = one cell: no diagonal fits
    expected = grid_graph(analysis.state != 1)
    np.testing.assert_array_equal(graph.indices, expected.indices)
    _check_separation(graph)


def test_a_robot_within_a_third_of_a_cell_gets_a_checkerboard_of_diagonals_too() -> None:
    analysis, graph = _synthetic(_pillars(), 0.01)  # 2r = 0.4 cell: one diagonal a block fits
    free = analysis.state != 1
    expected = grid_graph(free)
    np.testing.assert_array_equal(graph.cells, expected.cells)
    _check_separation(graph)
    _check_collision_free(graph, analysis)
    edges = {tuple(e) for e in naive_roadmap.elements(graph)[graph.nodes :].tolist()}
    assert {tuple(e) for e in naive_roadmap.elements(expected)[expected.nodes :].tolist()} <= edges
    index = {tuple(c): k for k, c in enumerate(graph.cells.tolist())}
    blocks = 0
    for r, c in itertools.product(range(free.shape[0] - 1), range(free.shape[1] - 1)):
        if not free[r : r + 2, c : c + 2].all():
            continue
        blocks += 1
        down = (index[r, c], index[r + 1, c + 1])
        up = tuple(sorted((index[r, c + 1], index[r + 1, c])))
        assert (down in edges, up in edges) == (((r + c) % 2 == 0), ((r + c) % 2 == 1))
    assert len(edges) == expected.edges + blocks


# attach and validation.


def test_attach_joins_the_nearest_node_in_sight_or_none() -> None:
    rows = _rooms(0.6)
    analysis, graph = _synthetic(rows, 0.2)
    node = attach(graph, analysis, [31, 30])
    distances = np.hypot(*(graph.cells - [31, 30]).T)
    assert distances[node] == distances.min()
    assert attach(graph, analysis, [0, 0]) == -1  # a wall
    assert attach_all(graph, analysis, np.zeros((0, 2), dtype=int)).tolist() == []


def test_a_start_heading_for_a_node_joins_the_node_that_leads_there_best() -> None:
    analysis, graph = _synthetic(_rooms(0.45), 0.2)  # a one-lane chain down the corridor
    inside = np.flatnonzero((graph.cells[:, 1] > 70) & (graph.cells[:, 1] < 110))
    inside = inside[np.argsort(graph.cells[inside, 1])]
    a, b = graph.cells[inside[1]], graph.cells[inside[2]]
    start = [int(a[0]), int((2 * a[1] + b[1]) // 3)]  # a third of the way from a to b
    east = attach(graph, analysis, [31, 150])
    assert attach(graph, analysis, start) == inside[1]
    assert attach(graph, analysis, start, toward=east) == inside[2]
    assert attach(graph, analysis, start, toward=int(inside[0])) == inside[1]
    with pytest.raises(planner.InvalidInput, match="toward"):
        attach(graph, analysis, start, toward=graph.nodes)


def test_attach_is_the_reference(ros: Path) -> None:
    analysis, graph = _ros(ros, "smoothers_world", 0.3)
    free = analysis.state != 1
    rng = np.random.default_rng(4)
    cells = np.argwhere(free)[rng.integers(int(free.sum()), size=60)]
    toward = rng.integers(-1, graph.nodes, size=60)
    reach = ATTACH_REACH * spacing(graph.radius / graph.resolution)
    got = attach_all(graph, analysis, cells, toward=toward)
    for cell, node, want in zip(cells.tolist(), toward.tolist(), got.tolist(), strict=True):
        assert naive_roadmap.attach(graph, free, tuple(cell), reach, node) == want, (cell, node)


def test_bad_input_is_refused() -> None:
    analysis, graph = _synthetic(_rooms(0.6), 0.2)
    with pytest.raises(planner.InvalidInput, match="radius"):
        build_roadmap(analysis, radius=-1.0)
    with pytest.raises(planner.InvalidInput, match="more than the analysis"):
        build_roadmap(analysis, radius=0.3)
    with pytest.raises(TypeError, match="Analysis"):
        build_roadmap(np.zeros((3, 3)), radius=0.1)  # type: ignore[arg-type]
    with pytest.raises(planner.InvalidInput, match="cells"):
        attach_all(graph, analysis, [[1.5, 2.0]])


def test_random_rooms_and_corridors_are_one_piece() -> None:
    """Two rooms joined by a corridor 2r + 0.05 m to 4r wide (benchmarks/fleet_scenarios.py):
    the roadmap joins them, through the corridor, on every geometry."""
    from tests.scripts import load_benchmark

    scenarios = load_benchmark("fleet_scenarios")
    for seed in range(40):
        scenario = scenarios.random_corridor_scenario(seed)
        params = planner.resolve_params("wide", robot_radius=scenario.radius)
        analysis = planner.analyse_map(scenario.robot_map, params)
        g = build_roadmap(analysis, radius=scenario.radius)
        pieces = len(set(naive_roadmap.components(g).tolist()))
        assert pieces == 1, (seed, pieces)

"""MAPF on a fleet's graph (planner/fleets): distance tables and PIBT against slow references,
LaCAM's answers checked by an independent validator on hand-made graphs (a swap that needs a
side pocket, a corridor, instances with no solution) and on Moving AI benchmark instances."""

from __future__ import annotations

import os
import random
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import shortest_path

import planner
from planner.fleets import Graph, grid_graph, solve
from planner.fleets.distances import cost_distances, step_distances
from planner.fleets.pibt import Pibt, tie_breaker
from tests import naive_mapf

# The shared Moving AI MAPF maps: beside the repository, or beside the folder holding it.
_ROOT = Path(__file__).resolve().parents[2]
_FOUND = [b / "shared" / "maps" / "mapf" for b in (_ROOT.parent, _ROOT.parent.parent)]
MAPF = next((p for p in _FOUND if p.is_dir()), _FOUND[0])


def _random_graph(seed: int, size: int = 7, density: float = 0.75) -> Graph:
    rng = np.random.default_rng(seed)
    return grid_graph(rng.random((size, size)) < density)


def _weighted(graph: Graph, seed: int) -> Graph:
    """``graph`` with random symmetric edge costs in [1, 3)."""
    rng = np.random.default_rng(seed)
    source = np.repeat(np.arange(graph.nodes), np.diff(graph.indptr))
    low, high = np.minimum(source, graph.indices), np.maximum(source, graph.indices)
    costs = 1 + 2 * rng.random((graph.nodes, graph.nodes))
    return Graph(
        graph.cells, graph.indptr.copy(), graph.indices.copy(), costs[low, high], graph.shape
    )


def _agents(graph: Graph, k: int, seed: int) -> tuple[list[int], list[int]]:
    rng = random.Random(seed)
    nodes = list(range(graph.nodes))
    return rng.sample(nodes, k), rng.sample(nodes, k)


@pytest.mark.parametrize("seed", range(6))
def test_step_distances_match_plain_bfs(seed: int) -> None:
    graph = _random_graph(seed)
    goals = list(range(0, graph.nodes, 5))
    table = step_distances(graph, goals)
    assert table.shape == (len(goals), graph.nodes)
    for row, goal in zip(table.tolist(), goals, strict=True):
        assert row == naive_mapf.bfs(graph, goal)


@pytest.mark.parametrize("seed", range(6))
def test_cost_distances_match_scipy_dijkstra(seed: int) -> None:
    graph = _weighted(_random_graph(seed), seed)
    source = np.repeat(np.arange(graph.nodes), np.diff(graph.indptr))
    matrix = csr_matrix((graph.costs, (source, graph.indices)), shape=(graph.nodes,) * 2)
    goals = np.arange(0, graph.nodes, 3)
    expected = shortest_path(matrix, method="D", directed=True, indices=goals)
    np.testing.assert_allclose(cost_distances(graph, goals), expected)
    plain = _random_graph(seed)  # equal costs: the BFS road
    np.testing.assert_array_equal(
        cost_distances(plain, goals),
        shortest_path(
            csr_matrix((plain.costs, (np.repeat(np.arange(plain.nodes), np.diff(plain.indptr)),
                        plain.indices)), shape=(plain.nodes,) * 2),
            method="D", indices=goals,
        ),
    )  # fmt: skip


def test_distances_name_a_goal_out_of_range() -> None:
    with pytest.raises(planner.InvalidInput, match="node 9 of agent 1") as info:
        step_distances(grid_graph([[1, 1]]), [0, 9])
    assert info.value.field == "goals"


def test_tie_breaker_matches_plain_integers() -> None:
    for node, salt in [(0, 0), (1, 5), (12345, 2**61 + 7), (2**20, 2**62 - 1)]:
        assert tie_breaker(node, salt) == naive_mapf.tie_breaker(node, salt)


@pytest.mark.parametrize("seed", range(40))
def test_pibt_step_matches_the_recursive_reference(seed: int) -> None:
    """Random configurations on random grids (narrow ones often, so that swaps and priority
    inheritance happen), sometimes with fixed moves: the same next configuration."""
    rng = random.Random(seed)
    graph = _random_graph(seed, size=rng.choice([4, 6, 8]), density=rng.choice([0.6, 0.8, 1.0]))
    if graph.nodes < 2:
        graph = _random_graph(seed, size=4, density=1.0)
    k = rng.randint(1, max(1, graph.nodes * 2 // 3))
    starts, goals = _agents(graph, k, seed)
    pref = cost_distances(graph, goals)
    pref[np.isinf(pref)] = graph.nodes  # a goal cut off: any finite preference will do
    fixed = [-1] * k
    for i in rng.sample(range(k), min(k, rng.choice([0, 0, 1, 2]))):
        fixed[i] = rng.choice([*graph.neighbours(starts[i]).tolist(), starts[i]])
    order = list(range(k))
    rng.shuffle(order)
    salt = rng.getrandbits(62)
    got = Pibt(graph, np.array(goals), pref).step(
        np.array(starts), np.array(order), np.array(fixed), salt
    )
    want = naive_mapf.pibt_step(graph, goals, pref, starts, order, fixed, salt)
    assert (None if got is None else got.tolist()) == want
    if want is not None:  # one valid step that keeps the fixed moves
        naive_mapf.check_solution(graph, starts, want, np.array([starts, want]))
        assert all(f < 0 or f == v for f, v in zip(fixed, want, strict=True))


def test_pibt_reports_colliding_fixed_moves() -> None:
    line = grid_graph([[1, 1, 1]])
    pibt = Pibt(line, np.array([2, 0]), cost_distances(line, [2, 0]))
    config, order = np.array([0, 2]), np.array([0, 1])
    assert pibt.step(config, order, np.array([1, 1])) is None  # both into node 1
    assert pibt.step(np.array([0, 1]), order, np.array([1, 0])) is None  # a swap


# The side pocket: nodes 0 1 2 on a row, 3 below 1.
POCKET = grid_graph([[1, 1, 1], [0, 1, 0]])


def _solved(graph: Graph, starts: list[int], goals: list[int], **options: object) -> int:
    found = solve(graph, starts, goals, **options)  # type: ignore[arg-type]
    assert found.status == "solved"
    soc, makespan = naive_mapf.check_solution(graph, starts, goals, found.paths)
    assert (found.sum_of_costs, found.makespan) == (soc, makespan)
    assert found.lower_bound == sum(
        naive_mapf.bfs(graph, g)[s] for s, g in zip(starts, goals, strict=True)
    )
    assert found.sum_of_costs >= found.lower_bound
    return soc


def test_a_swap_through_a_side_pocket() -> None:
    assert _solved(POCKET, [0, 2], [2, 0]) >= 7
    assert _solved(POCKET, [0, 2], [2, 0], refine=True) == 7  # the least: one waits, one hides


def test_a_corridor_of_agents_following_one_another() -> None:
    corridor = grid_graph(np.ones((1, 8)))
    assert _solved(corridor, [0, 1, 2], [5, 6, 7]) == 15
    assert _solved(corridor, [7, 6], [1, 0]) == 12


def test_a_crowded_grid_and_a_crowded_grid_with_costs() -> None:
    for seed in range(5):
        graph = _random_graph(seed, size=8)
        starts, goals = _agents(graph, graph.nodes // 3, seed)
        reach = step_distances(graph, goals)
        if all(reach[a, s] >= 0 for a, s in enumerate(starts)):
            _solved(graph, starts, goals, seed=seed)
            _solved(_weighted(graph, seed), starts, goals, seed=seed)


def test_no_room_to_pass_is_unsolvable() -> None:
    for graph, starts, goals in [
        (grid_graph([[1, 1]]), [0, 1], [1, 0]),
        (grid_graph([[1, 1, 1, 1]]), [0, 3], [3, 0]),
        (grid_graph([[1, 1, 1, 1]]), [0, 1, 2], [2, 1, 0]),
    ]:
        found = solve(graph, starts, goals)
        assert found.status == "unsolvable"
        assert found.paths.shape == (0, len(starts))
        assert found.sum_of_costs == found.makespan == 0


def test_a_goal_out_of_reach_is_unsolvable_at_once() -> None:
    apart = grid_graph([[1, 0, 1]])
    found = solve(apart, [0], [1])
    assert (found.status, found.lower_bound, found.expanded) == ("unsolvable", -1, 0)


def test_blocked_nodes_are_never_entered() -> None:
    grid = grid_graph(np.ones((3, 3)))  # nodes row by row
    blocked = np.zeros(9, dtype=bool)
    blocked[4] = True  # the centre
    found = solve(grid, [0, 8], [8, 0], blocked=blocked)
    assert found.status == "solved"
    naive_mapf.check_solution(grid, [0, 8], [8, 0], found.paths)
    assert 4 not in found.paths
    wall = np.zeros(9, dtype=bool)
    wall[[3, 4, 5]] = True
    assert solve(grid, [0], [8], blocked=wall).status == "unsolvable"


def test_a_deadline_already_past_is_a_timeout_and_seeds_repeat() -> None:
    graph = grid_graph(np.ones((6, 6)))
    starts, goals = _agents(graph, 20, 3)
    assert solve(graph, starts, goals, time_limit_s=1e-9).status == "timeout"
    first = solve(graph, starts, goals, seed=4)
    assert np.array_equal(first.paths, solve(graph, starts, goals, seed=4).paths)


def test_no_agents_and_agents_already_home() -> None:
    assert solve(POCKET, [], []).paths.shape == (1, 0)
    home = solve(POCKET, [0, 3], [0, 3])
    assert (home.status, home.paths.tolist(), home.sum_of_costs) == ("solved", [[0, 3]], 0)


@pytest.mark.parametrize(
    ("starts", "goals", "options", "field", "words"),
    [
        ([0, 7], [1, 2], {}, "starts", "node 7 of agent 1 is not in 0..3"),
        ([0, 1], [1, -1], {}, "goals", "node -1 of agent 1"),
        ([0, 1, 0], [1, 2, 3], {}, "starts", "agents 0 and 2 share node 0"),
        ([0, 1], [2, 2], {}, "goals", "agents 0 and 1 share node 2"),
        ([0, 1], [2], {}, "goals", "1 given for 2 starts"),
        ([0.5], [1], {}, "starts", "node indices expected"),
        ([[0, 1]], [1, 2], {}, "starts", "node indices expected"),
        ([0], [1], {"time_limit_s": 0}, "time_limit_s", "positive number"),
        ([0], [1], {"time_limit_s": float("nan")}, "time_limit_s", "positive number"),
        ([0], [1], {"blocked": [1, 0, 0, 0]}, "blocked", r"bool per node \(4,\)"),
        ([0], [1], {"blocked": np.ones(3, dtype=bool)}, "blocked", "bool per node"),
        ([0], [1], {"blocked": np.array([1, 0, 0, 0], dtype=bool)}, "starts", "0 of agent 0"),
        ([0], [1], {"blocked": np.array([0, 1, 0, 0], dtype=bool)}, "goals", "1 of agent 0 is"),
    ],
)
def test_invalid_input_names_the_agent_and_value(
    starts: object, goals: object, options: dict[str, object], field: str, words: str
) -> None:
    with pytest.raises(planner.InvalidInput, match=words) as info:
        solve(POCKET, starts, goals, **options)  # type: ignore[arg-type]
    assert info.value.field == field


INSTANCES = [
    ("empty-32-32", "random-1", 60),
    ("random-32-32-10", "random-1", 50),
    ("room-32-32-4", "even-1", 40),
    ("maze-32-32-2", "random-1", 30),
    ("den312d", "random-1", 80),
    ("warehouse-10-20-10-2-1", "random-1", 80),
]


@pytest.mark.parametrize(("name", "scen", "agents"), INSTANCES)
def test_moving_ai_instances_are_solved_and_valid(name: str, scen: str, agents: int) -> None:
    if not MAPF.is_dir():
        if os.environ.get("CI"):
            pytest.fail(f"Moving AI MAPF maps not found at {MAPF}")
        pytest.skip(f"Moving AI MAPF maps not found at {MAPF}")
    graph = grid_graph(planner.read_map(MAPF / f"{name}.map") == 0)
    lines = planner.read_scen(MAPF / f"{name}-{scen}.scen")[:agents]
    starts = graph.node_of([line.start for line in lines]).tolist()
    goals = graph.node_of([line.goal for line in lines]).tolist()
    assert min(starts) >= 0
    assert min(goals) >= 0
    found = solve(graph, starts, goals, time_limit_s=30)
    assert found.status == "solved"
    soc, makespan = naive_mapf.check_solution(graph, starts, goals, found.paths)
    assert (found.sum_of_costs, found.makespan) == (soc, makespan)
    assert found.lower_bound == int(step_distances(graph, goals)[np.arange(agents), starts].sum())
    assert soc >= found.lower_bound

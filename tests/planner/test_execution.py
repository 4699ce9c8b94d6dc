"""The action dependency graph: joint plans executed in random orders, at random paces, with
pauses, never put two robots where they may meet and never deadlock."""

from __future__ import annotations

import itertools
import random

import numpy as np
import pytest

from planner.fleets import Schedule, grid_graph, schedule, segment_distances, solve, timed_moves


def _places(moves: list[tuple[int, int, int]], done: int, told: int) -> set[int]:
    """The nodes a robot may be on: its first move not done's source, and every told target."""
    if not moves:
        return set()
    if done >= len(moves):
        return {moves[-1][1]}
    return {moves[done][0], *(moves[k][1] for k in range(done, told))}


def _execute(plan: Schedule, starts: list[int], seed: int, *, pause: float = 0.2) -> int:
    """Steps robots in a random order (each step: its told moves done, then its ready moves
    told, at most a random few), some robots pausing for a while; asserts that no two robots may
    share a node at any time. Returns the ticks until every robot is done."""
    rng = random.Random(seed)
    k = len(plan.moves)
    done, told = [0] * k, [0] * k
    paused = [0] * k
    for tick in range(1, 20_000):
        if all(d == len(m) for d, m in zip(done, plan.moves, strict=False)):
            return tick
        order = list(range(k))
        rng.shuffle(order)
        for j in order[: rng.randint(1, k)]:  # skipped ticks: only some robots step
            if paused[j]:
                paused[j] -= 1
                continue
            if rng.random() < pause / 10:
                paused[j] = rng.randint(1, 20)
                continue
            done[j] = told[j]
            end, _ = plan.ready(j, told[j], done)
            told[j] = min(end, told[j] + rng.randint(1, 3))
            places = [
                _places(list(plan.moves[i]), done[i], told[i]) or {starts[i]} for i in range(k)
            ]
            for a in range(k):
                for b in range(a + 1, k):
                    assert not places[a] & places[b], (tick, a, b, places[a], places[b])
    raise AssertionError("the fleet did not finish: a deadlock")


def test_a_swap_through_a_pocket_runs_in_any_order() -> None:
    # A corridor with a pocket above its middle: two robots swap ends.
    free = np.zeros((2, 5), dtype=bool)
    free[1, :] = True
    free[0, 2] = True
    graph = grid_graph(free)
    left, right = graph.node_of([[1, 0], [1, 4]]).tolist()
    solution = solve(graph, [left, right], [right, left], time_limit_s=5.0)
    assert solution.status == "solved"
    moves = timed_moves(solution.paths, [[], []])
    plan = schedule(moves, graph.cells.astype(float), roadmap_nodes=graph.nodes, reach=0.0)
    for seed in range(200):
        _execute(plan, [left, right], seed)


@pytest.mark.parametrize("seed", range(6))
def test_random_fleets_on_a_random_grid_never_meet_nor_deadlock(seed: int) -> None:
    rng = np.random.default_rng(seed)
    free = rng.random((12, 12)) > 0.2
    graph = grid_graph(free)
    # The largest connected part's nodes, as starts and goals.
    nodes = rng.permutation(graph.nodes)
    k = 12
    solution = solve(graph, nodes[:k].tolist(), nodes[k : 2 * k].tolist(), time_limit_s=5.0)
    if solution.status != "solved":
        pytest.skip(f"instance {seed} is {solution.status}")
    moves = timed_moves(solution.paths, [[] for _ in range(k)])
    plan = schedule(moves, graph.cells.astype(float), roadmap_nodes=graph.nodes, reach=0.0)
    for order in range(20):
        _execute(plan, nodes[:k].tolist(), 1000 * seed + order)


def test_dependencies_point_from_earlier_plan_times_to_later_ones() -> None:
    # Every dependency's move starts no later in the plan than the move that waits for it: the
    # graph has no cycle, whatever the instance.
    rng = np.random.default_rng(7)
    graph = grid_graph(rng.random((10, 10)) > 0.15)
    nodes = rng.permutation(graph.nodes)
    solution = solve(graph, nodes[:15].tolist(), nodes[15:30].tolist(), time_limit_s=5.0)
    assert solution.status == "solved"
    plan = schedule(
        timed_moves(solution.paths, [[] for _ in range(15)]), graph.cells.astype(float),
        roadmap_nodes=graph.nodes, reach=0.0,
    )  # fmt: skip
    for j, own in enumerate(plan.after):
        for k, deps in enumerate(own):
            for i, m in deps:
                assert i != j
                assert plan.moves[i][m][2] <= plan.moves[j][k][2]
                assert plan.moves[i][m][0] == plan.moves[j][k][1]


def test_a_move_told_before_the_solve_is_waited_for() -> None:
    # Robot 0 was told 0 -> 1 before the fleet was solved again, and may still be moving: the
    # new plan's move of robot 1 into node 0 waits until robot 0 reports it done.
    moves = timed_moves(np.array([[1, 3], [2, 3], [2, 0]]), [[0, 1], []])
    assert moves == [[(0, 1, -1), (1, 2, 0)], [(3, 0, 1)]]
    graph = grid_graph(np.ones((2, 2), dtype=bool))
    plan = schedule(moves, graph.cells.astype(float), roadmap_nodes=4, reach=0.0)
    assert plan.after[1][0] == ((0, 0),)
    assert plan.ready(1, 0, [0, 0]) == (0, 0)
    assert plan.ready(1, 0, [1, 0]) == (1, None)


def test_off_roadmap_places_are_kept_clear_by_distance() -> None:
    # Robot 0 joins from a point beside node 1 (node 4, off the roadmap); robot 1's move past it
    # waits for robot 0 to be on the roadmap.
    graph = grid_graph(np.ones((1, 4), dtype=bool))
    points = np.concatenate([graph.cells.astype(float), [[1.0, 1.0]]])
    moves = [[(4, 1, -1), (1, 0, 0)], [(3, 2, 0), (2, 1, 1)]]
    plan = schedule(moves, points, roadmap_nodes=4, reach=1.5)
    assert (0, 0) in plan.after[1][0]  # 3 -> 2 passes within 1.5 of the point (1, 1)
    assert plan.blocker(1, 0, [0, 0]) == 0
    assert plan.blocker(1, 0, [1, 0]) is None


def test_segment_distances_match_a_dense_sampling() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        p, q = rng.random(2) * 4, rng.random(2) * 4
        a, b = rng.random((5, 2)) * 4, rng.random((5, 2)) * 4
        if rng.random() < 0.2:
            q = p.copy()
        exact = segment_distances(p, q, a, b)
        t = np.linspace(0, 1, 201)
        first = p + (q - p) * t[:, None]
        for i in range(5):
            second = a[i] + (b[i] - a[i]) * t[:, None]
            sampled = np.min(np.linalg.norm(first[:, None] - second[None], axis=2))
            assert exact[i] <= sampled + 1e-9
            assert sampled - exact[i] < 0.05


@pytest.mark.parametrize("seed", range(3))
def test_robots_on_a_roadmap_executed_in_any_order_keep_their_radii_apart(seed: int) -> None:
    """The roadmap's separation and the schedule's order together: robots of 0.25 m on a room
    with pillars, executed in random orders with pauses; at every moment the places each robot
    may be (its first move not done, through every move it was told) keep 2r from every other
    robot's, measured exactly between segments."""
    import planner
    from planner.fleets import build_roadmap

    rng = np.random.default_rng(seed)
    occ = np.zeros((80, 80), dtype=np.int8)
    for _ in range(12):
        r, c = rng.integers(8, 72, size=2)
        occ[r - 2 : r + 3, c - 2 : c + 3] = 1
    robot_map = planner.grid_map(occ, resolution=0.05)
    analysis = planner.analyse_map(
        robot_map, planner.resolve_params("wide", robot_radius=0.25, unknown="free")
    )
    graph = build_roadmap(analysis, radius=0.25)
    labels = graph.pieces()
    largest = np.nonzero(labels == np.argmax(np.bincount(labels)))[0]
    k = min(10, len(largest) // 3)
    nodes = rng.permutation(largest)
    solution = solve(graph, nodes[:k].tolist(), nodes[k : 2 * k].tolist(), time_limit_s=5.0)
    assert solution.status == "solved"
    moves = timed_moves(solution.paths, [[] for _ in range(k)])
    points = graph.cells.astype(float)
    plan = schedule(moves, points, roadmap_nodes=graph.nodes, reach=2 * 0.25 / 0.05)
    reach = 2 * 0.25 / 0.05 - 1e-6
    for order in range(10):
        random_ = random.Random(order)
        done, told = [0] * k, [0] * k
        for _ in range(5000):
            if all(d == len(m) for d, m in zip(done, plan.moves, strict=True)):
                break
            j = random_.randrange(k)
            done[j] = told[j]
            end, _ = plan.ready(j, told[j], done)
            told[j] = min(end, told[j] + random_.randint(1, 3))
            chains = []
            for i in range(k):
                own = plan.moves[i]
                if not own:
                    chains.append([int(nodes[i])] * 2)
                elif done[i] >= len(own):
                    chains.append([own[-1][1]] * 2)
                else:
                    chain = [own[done[i]][0], *(own[m][1] for m in range(done[i], told[i]))]
                    chains.append(chain if len(chain) > 1 else chain * 2)
            for a in range(k):
                pa = points[chains[a]]
                for b in range(a + 1, k):
                    pb = points[chains[b]]
                    for p, q in itertools.pairwise(pa):
                        assert segment_distances(p, q, pb[:-1], pb[1:]).min() >= reach
        else:
            raise AssertionError("a deadlock")

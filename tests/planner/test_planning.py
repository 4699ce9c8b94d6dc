"""plan(): presets, decisions, the narrow fallback, and errors that name the value."""

from __future__ import annotations

import math

import numpy as np
import pytest

import planner
from planner.cli import EXAMPLE_GOAL, EXAMPLE_MAP, EXAMPLE_START
from tests.conftest import grid_from

# An open room with a long wall: start and goal both stand against it.
ROOM_WITH_WALL = np.zeros((10, 24), dtype=np.uint8)
ROOM_WITH_WALL[6, 2:22] = 1


def test_wide_takes_the_wide_route_and_shortest_hugs_the_wall() -> None:
    grid = planner.read_map(str(EXAMPLE_MAP))
    wide = planner.plan(grid, EXAMPLE_START, EXAMPLE_GOAL, preset="wide")
    short = planner.plan(grid, EXAMPLE_START, EXAMPLE_GOAL, preset="shortest")
    # shortest goes straight through the one-cell corridor in row 7; wide goes round above.
    assert (short.path[:, 0] == 7).all()
    assert short.length == pytest.approx(24.0)
    assert short.contact_ratio > 0.5
    assert wide.path[:, 0].min() <= 3
    assert wide.min_clearance >= 2.0
    assert wide.contact_ratio == 0.0
    assert wide.length > short.length
    assert wide.mean_clearance > short.mean_clearance


def test_wide_keeps_off_a_wall_the_shortest_path_follows() -> None:
    start, goal = (5, 2), (5, 21)
    short = planner.plan(ROOM_WITH_WALL, start, goal, preset="shortest")
    wide = planner.plan(ROOM_WITH_WALL, start, goal, preset="wide")
    assert (short.path[:, 0] == 5).all()  # straight along the wall
    assert short.contact_ratio == 1.0
    assert wide.path[:, 0].min() <= 3  # steps away from it
    assert wide.contact_ratio < 0.3
    assert wide.mean_clearance > short.mean_clearance + 1
    assert short.length < wide.length < 1.3 * short.length


def test_presets_are_the_papers() -> None:
    p = planner.PRESETS
    assert p["wfs-mmas"].decision == "paper"
    assert (p["wfs-mmas"].seal_tunnels, p["wfs-mmas"].clean_weight) == (True, 0.5)
    assert (p["wfs-mmas"].clean_radius, p["wfs-mmas"].diagonal_cost) == (1, 1.4)
    assert (p["mmas"].seal_tunnels, p["mmas"].clean_weight, p["mmas"].diagonal_cost) == (
        False,
        0.0,
        1.4,
    )
    assert (p["wide"].decision, p["wide"].clean_radius) == ("wide", 2)
    assert p["wide"].diagonal_cost == pytest.approx(math.sqrt(2))
    assert (p["shortest"].seal_tunnels, p["shortest"].clean_weight) == (False, 0.0)
    for params in p.values():
        assert (params.alpha, params.beta) == (3.0, 1.0)


def test_rho_is_refused_with_the_reason() -> None:
    with pytest.raises(planner.InvalidInput, match="rho is not a parameter") as info:
        planner.resolve_params("wfs-mmas", rho=0.5)
    assert info.value.field == "params.rho"


def test_parameters_override_one_by_one() -> None:
    grid = np.zeros((6, 6), dtype=np.uint8)
    p = planner.plan(grid, (0, 0), (5, 5), preset="mmas", alpha=5, beta=0)
    assert (p.params.alpha, p.params.beta, p.params.decision) == (5.0, 0.0, "paper")
    assert p.params.diagonal_cost == 1.4
    assert p.length == pytest.approx(5 * math.sqrt(2))  # a length: 1.4 weighs the search only


@pytest.mark.parametrize(
    ("params", "message"),
    [
        (
            {"preset": "fastest"},
            "unknown preset 'fastest'; choose one of mmas, shortest, wfs-mmas, wide",
        ),
        ({"alpha": -1}, r"alpha must be in \[0.0, 20.0\]; got -1"),
        ({"alpha": "3"}, "alpha must be a number; got '3'"),
        ({"clean_radius": 1.5}, "clean_radius must be an integer; got 1.5"),
        ({"seal_tunnels": 1}, "seal_tunnels must be true or false; got 1"),
        ({"decision": "greedy"}, "decision must be 'wide' or 'paper'; got 'greedy'"),
        ({"diagonal_cost": 3}, r"diagonal_cost must be in \[1.0, 2.0\]; got 3"),
        ({"patience": True}, "patience must be an integer; got True"),
        ({"gamma": 1}, "unknown parameter 'gamma'"),
    ],
)
def test_bad_parameters_are_named(params: dict[str, object], message: str) -> None:
    with pytest.raises(planner.InvalidInput, match=message) as info:
        planner.plan(np.zeros((3, 3), dtype=np.uint8), (0, 0), (2, 2), **params)  # type: ignore[arg-type]
    assert info.value.field in ("preset", *(f"params.{k}" for k in params))


@pytest.mark.parametrize(
    ("start", "goal", "message", "field"),
    [
        ((0, 1), (2, 2), r"start \[0, 1\] is on an obstacle", "start"),
        ((0, 0), (1, 1), r"goal \[1, 1\] is on an obstacle", "goal"),
        ((3, 0), (2, 2), r"start \[3, 0\] is outside the 3 x 3 map", "start"),
        ((0, 0), (2, -1), r"goal \[2, -1\] is outside the 3 x 3 map", "goal"),
        (
            (0, 0, 0),
            (2, 2),
            r"start must be a \[row, col\] pair of integers; got \(0, 0, 0\)",
            "start",
        ),
        ((0, 0), "22", "goal must be a \\[row, col\\] pair; got '22'", "goal"),
        ((0.5, 0), (2, 2), "start must be a \\[row, col\\] pair of integers", "start"),
    ],
)
def test_bad_start_or_goal_is_named(start: object, goal: object, message: str, field: str) -> None:
    grid = grid_from("#.#\n.#.\n...").copy()
    grid[0, 0] = 0
    grid[0, 1] = 1
    with pytest.raises(planner.InvalidInput, match=message) as info:
        planner.plan(grid, start, goal)
    assert info.value.field == field


def test_unreachable_goal_raises_no_valid_path() -> None:
    grid = grid_from(
        """
        ..#..
        ..#..
        ..#..
        """
    )
    for preset in planner.PRESETS:
        with pytest.raises(planner.NoValidPath, match=r"^NO_VALID_PATH: goal \[0, 4\]") as info:
            planner.plan(grid, (0, 0), (0, 4), preset=preset)
        assert info.value.code == "NO_VALID_PATH"


def test_start_equal_to_goal_is_a_one_cell_path() -> None:
    p = planner.plan(np.zeros((3, 3), dtype=np.uint8), (1, 1), (1, 1))
    assert p.path.tolist() == [[1, 1]]
    assert (p.length, p.arc_cost) == (0.0, 0.0)


def test_arc_cost_is_the_sum_of_k_over_the_cells_entered() -> None:
    grid = np.zeros((1, 5), dtype=np.uint8)
    p = planner.plan(grid, (0, 0), (0, 4), preset="shortest")
    assert p.arc_cost == pytest.approx(3 + 2 + 1 + 0)
    assert p.length == 4.0


def test_paper_decision_follows_eq3_with_the_least_p() -> None:
    # In the open, the least S = (k + clean)^alpha * h^beta is the neighbour nearest the goal.
    grid = np.zeros((8, 8), dtype=np.uint8)
    p = planner.plan(grid, (0, 0), (7, 7), preset="mmas")
    assert p.path.tolist() == [[i, i] for i in range(8)]
    assert p.length == pytest.approx(7 * math.sqrt(2))


def test_paper_decision_uses_the_tabu_list_then_the_wide_step() -> None:
    # A dead-end pocket: Eq. 3 walks in greedily; when all feasible neighbours are tabu it takes
    # the wide decision, so the walk still ends at the goal.
    grid = grid_from(
        """
        .......
        .#####.
        .#...#.
        .#.#.#.
        .......
        """
    )
    for preset in ("wfs-mmas", "mmas"):
        p = planner.plan(grid, (2, 2), (4, 6), preset=preset)
        assert p.path[-1].tolist() == [4, 6]


def test_a_given_analysis_must_match_the_parameters() -> None:
    grid = np.zeros((4, 4), dtype=np.uint8)
    a = planner.analyse(grid, seal_tunnels=False, clean_weight=0.0, clean_radius=1)
    p = planner.plan(None, (0, 0), (3, 3), preset="shortest", analysis=a)
    assert p.analysis is a
    with pytest.raises(ValueError, match="other parameters"):
        planner.plan(None, (0, 0), (3, 3), preset="wide", analysis=a)


def test_waves_source_is_used_for_the_narrow_fallback() -> None:
    grid = grid_from("....\n##.#\n....")
    a = planner.analyse(grid)
    asked: list[bool] = []

    def waves(goal: tuple[int, int], narrow: bool) -> planner.Wave:
        asked.append(narrow)
        return planner.goal_wave(a, goal, narrow=narrow)

    p = planner.plan(None, (0, 0), (2, 0), analysis=a, waves=waves)
    assert asked == [False, True]
    assert p.narrow_fallback

"""Bounded detours: the ``wide`` route is never longer than ``params.max_detour`` times the
shortest route on the same configuration space; it gives up width first, and says so."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import planner
from planner import InvalidInput, NoValidPath
from planner.plans.bounded import SCALES, Detour, scaled_analysis

RES = 0.05
START, GOAL = {"x": 1.5, "y": 6.0}, {"x": 4.5, "y": 6.2}


def fence() -> planner.RobotMap:
    """A 6 x 7 m room split by a fence of 0.3 m pillars 0.80 m apart, open 1.7 m at its foot:
    the wide way round is more than three times as long as the way between two pillars."""
    grid = np.zeros((140, 120), dtype=np.int8)
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 1
    for r in range(0, 100, 22):
        grid[r : r + 6, 57:63] = 1
    return planner.grid_map(grid, resolution=RES)


def shortest(robot_map: planner.RobotMap, radius: float) -> planner.Plan:
    return planner.plan(robot_map, START, GOAL, preset="shortest", robot_radius=radius)


@pytest.mark.parametrize("max_detour", [1.0, 1.1, 1.3, 2.0])
def test_pillars_080_apart_the_route_stays_within_the_bound(max_detour: float) -> None:
    robot_map = fence()
    free = planner.plan(robot_map, START, GOAL, robot_radius=0.22, max_detour=100.0)
    short = shortest(robot_map, 0.22)
    assert free.length > 3 * short.length  # unbounded, wide goes round the fence
    p = planner.plan(robot_map, START, GOAL, robot_radius=0.22, max_detour=max_detour)
    assert p.length <= max_detour * short.length * (1 + 1e-9)
    detour = p.summary()["detour"]
    assert detour["shortest_m"] == pytest.approx(short.length_m)
    assert detour["ratio"] == pytest.approx(p.length / short.length, abs=1e-6)
    assert detour["width_kept"] < 1  # width given up, as little as the steps allow
    assert p.params.wide_weight == 80.0 * detour["width_kept"]
    assert p.params.max_detour == max_detour
    wider = [s for s in (1.0, *SCALES) if s > detour["width_kept"]]
    for scale in wider:  # every wider trial was over the bound
        trial = planner.plan(
            robot_map, START, GOAL, robot_radius=0.22, max_detour=100.0, wide_weight=80.0 * scale
        )
        assert trial.length > max_detour * short.length


def test_within_the_bound_nothing_is_given_up() -> None:
    p = planner.plan(fence(), {"x": 1.5, "y": 1.0}, {"x": 4.5, "y": 1.0}, robot_radius=0.22)
    detour = p.summary()["detour"]
    assert detour["width_kept"] == 1.0
    assert p.params.wide_weight == 80.0
    assert detour["ratio"] <= 1.3


def test_the_effective_params_plan_the_same_route() -> None:
    """A plan rebuilt from its record's params (the weights given up) follows the same path:
    the wall term scaled by a power of two is the analysis of the scaled weight to the bit."""
    robot_map = fence()
    p = planner.plan(robot_map, START, GOAL, robot_radius=0.22)
    assert p.params.wide_weight < 80.0
    again = planner.plan(robot_map, START, GOAL, **{**p.params.as_dict(), "max_detour": 100.0})
    np.testing.assert_array_equal(again.path, p.path)
    assert again.analysis.clean.tobytes() == p.analysis.clean.tobytes()


def test_the_paper_decision_is_not_bounded() -> None:
    p = planner.plan([[0, 0, 0], [0, 1, 0], [0, 0, 0]], [0, 0], [2, 2], preset="wfs-mmas")
    assert p.detour is None
    assert planner.plan([[0, 0], [0, 0]], [0, 0], [1, 1], preset="shortest").detour is None


@pytest.mark.parametrize(
    ("value", "words"),
    [
        (0.99, "max_detour must be a finite number from 1 to 100"),
        (math.inf, "finite number"),
        (math.nan, "finite number"),
        (101, "from 1 to 100"),
        ("2", "max_detour must be a number"),
        (True, "max_detour must be a number"),
    ],
)
def test_max_detour_is_checked(value: object, words: str) -> None:
    with pytest.raises(InvalidInput) as info:
        planner.resolve_params("wide", max_detour=value)
    assert info.value.field == "params.max_detour"
    assert words in info.value.message


@settings(max_examples=60, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(6, 24),
    st.integers(6, 24),
    st.floats(0.0, 0.45),
    st.floats(1.0, 2.0),
    st.sampled_from(["wide", "wfs-mmas"]),
    st.booleans(),
)
def test_never_longer_than_max_detour_times_the_shortest(
    seed: int, H: int, W: int, density: float, max_detour: float, preset: str, whole: bool
) -> None:
    """On random maps, the ``wide`` route is at most ``max_detour`` times the shortest route
    (the ``shortest`` preset: tunnels open, no wall term), whatever the weights given. With
    whole-map waves, the shortest route is read off the plan's own wave where its grid is the
    unsealed one (no tunnel sealed, or the narrow fallback): the same length."""
    rng = np.random.default_rng(seed)
    grid = (rng.random((H, W)) < density).astype(np.int8)
    free = np.argwhere(grid == 0)
    assume(len(free) >= 2)
    start, goal = (free[i].tolist() for i in rng.choice(len(free), 2, replace=False))
    weight = float(rng.choice([0.5, 2.0, 8.0]))
    try:
        short = planner.plan(grid, start, goal, preset="shortest")
    except NoValidPath:
        assume(False)
        return
    p = planner.plan(  # wfs-mmas: the paper's sealing and weights, with the wide decision
        grid, start, goal, preset=preset, decision="wide", clean_weight=weight,
        diagonal_cost=math.sqrt(2), max_detour=max_detour, whole=whole,
    )  # fmt: skip
    assert p.length <= max_detour * short.length * (1 + 1e-9) + 1e-9
    assert p.detour is not None
    assert p.detour.shortest == pytest.approx(short.length)


@pytest.mark.parametrize("max_detour", [1.0, 1.3, 2.0])
def test_a_route_through_waypoints_stays_within_the_bound_as_a_whole(max_detour: float) -> None:
    """Through a waypoint on the far side of the fence and back, the route is at most
    ``max_detour`` times the shortest route through the same waypoint (each leg's shortest,
    summed), with one share of the wall term for every leg."""
    robot_map, via = fence(), [{"x": 4.5, "y": 5.0}]
    free = planner.plan(robot_map, START, GOAL, waypoints=via, robot_radius=0.22, max_detour=100)
    legs = [  # the shortest legs: start -> waypoint -> goal
        planner.plan(robot_map, a, b, preset="shortest", robot_radius=0.22)
        for a, b in ((START, via[0]), (via[0], GOAL))
    ]
    short = sum(leg.length for leg in legs)
    assert free.length > 2 * short  # unbounded, wide goes round the fence
    p = planner.plan(
        robot_map, START, GOAL, waypoints=via, robot_radius=0.22, max_detour=max_detour
    )
    assert p.route is not None
    assert len(p.route.legs) == 2
    assert p.length <= max_detour * short * (1 + 1e-9)
    assert sum(leg.length for leg in p.route.legs) == pytest.approx(p.length)
    detour = p.summary()["detour"]
    assert detour["shortest_m"] == pytest.approx(short * RES)
    assert detour["width_kept"] < 1
    assert {leg.params.wide_weight for leg in p.route.legs} == {p.params.wide_weight}
    assert p.params.wide_weight == 80.0 * detour["width_kept"]
    for leg in p.route.legs:  # each leg planned again from the route's params: the same path
        again = planner.plan(
            robot_map, leg.start, leg.goal, **{**p.params.as_dict(), "max_detour": 100.0}
        )
        if not leg.narrow_fallback:
            np.testing.assert_array_equal(again.path, leg.path)


def test_a_route_within_the_bound_gives_nothing_up() -> None:
    via = [{"x": 1.5, "y": 3.0}]
    p = planner.plan(fence(), {"x": 1.5, "y": 1.0}, {"x": 4.5, "y": 1.0}, waypoints=via,
                     robot_radius=0.22)  # fmt: skip
    assert p.detour is not None
    assert p.detour.width_kept == 1.0
    assert p.params.wide_weight == 80.0


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(6, 20), st.integers(6, 20), st.floats(1.0, 2.0))
def test_routes_through_waypoints_on_random_maps(
    seed: int, H: int, W: int, max_detour: float
) -> None:
    """On random maps, a ``wide`` route through 1-3 waypoints is at most ``max_detour`` times
    the sum of its legs' shortest routes."""
    rng = np.random.default_rng(seed)
    grid = (rng.random((H, W)) < 0.3).astype(np.int8)
    free = np.argwhere(grid == 0)
    count = int(rng.integers(1, 4))
    assume(len(free) >= count + 2)
    ends = [free[i].tolist() for i in rng.choice(len(free), count + 2, replace=False)]
    try:
        short = sum(
            planner.plan(grid, a, b, preset="shortest").length for a, b in itertools.pairwise(ends)
        )
    except NoValidPath:
        assume(False)
        return
    p = planner.plan(
        grid, ends[0], ends[-1], waypoints=ends[1:-1], clean_weight=8.0,
        diagonal_cost=math.sqrt(2), max_detour=max_detour,
    )  # fmt: skip
    assert p.length <= max_detour * short * (1 + 1e-9) + 1e-9
    assert p.detour is not None
    assert p.detour.shortest == pytest.approx(short)


def test_among_tb3_sandboxs_pillars(ros: Path) -> None:
    """tb3_sandbox's pillars stand 0.80 m apart: unbounded, a wide route across them goes round
    at twice the shortest length; bounded, within 1.3 times it."""
    robot_map = planner.read_ros_map(ros / "tb3_sandbox.yaml")
    start, goal = {"x": -0.6, "y": -1.2}, {"x": 1.2, "y": 0.6}
    short = planner.plan(robot_map, start, goal, preset="shortest", robot_radius=0.22)
    free = planner.plan(robot_map, start, goal, robot_radius=0.22, max_detour=100.0)
    assert free.length > 2 * short.length
    p = planner.plan(robot_map, start, goal, robot_radius=0.22)
    assert p.length <= 1.3 * short.length * (1 + 1e-9)
    assert p.detour is not None
    assert p.detour.width_kept < 1


@pytest.mark.parametrize("robot_radius", [0.0, 0.15])
def test_a_scaled_wall_term_is_the_analysis_of_the_scaled_weight(robot_radius: float) -> None:
    """Both wall terms (``cells`` on a plain grid, ``meters`` with a radius), every share."""
    grid = (np.random.default_rng(3).random((40, 50)) < 0.2).astype(np.int8)
    robot_map = planner.grid_map(grid, resolution=1.0 if robot_radius == 0 else 0.05)
    params = planner.resolve_params("wide", robot_radius=robot_radius, clean_weight=0.7)
    full = planner.analyse_map(robot_map, params)
    for scale in SCALES:
        scaled = planner.resolve_params(
            "wide", robot_radius=robot_radius, clean_weight=0.7 * scale, wide_weight=80.0 * scale
        )
        mine = scaled_analysis(full, scaled, scale)
        theirs = planner.analyse_map(robot_map, scaled)
        assert mine.clean.tobytes() == theirs.clean.tobytes()
        assert mine.params_key == theirs.params_key
        assert mine.penalised == theirs.penalised


@pytest.mark.parametrize("whole", [False, True])
def test_the_bound_measures_the_shortest_route_through_sealed_tunnels(whole: bool) -> None:
    """A wall with a one-cell corridor (sealed) and a wide way round below it: the shortest
    route runs through the corridor, so the wide one round (1.6 times longer) is over the bound
    and the plan opens the tunnel. The whole-map wave of the sealed grid must not stand in for
    the shortest route's (it reuses the plan's wave only on the same grid)."""
    grid = np.zeros((17, 21), dtype=np.uint8)
    grid[:13, 9:12] = 1
    grid[3, 9:12] = 0
    assert planner.analyse(grid).sealed == 3
    p = planner.plan(grid, [3, 0], [3, 20], preset="wide", whole=whole, max_detour=1.3)
    assert p.detour == Detour(20.0, width_kept=0.0, tunnels_opened=True)
    assert p.length == 20.0

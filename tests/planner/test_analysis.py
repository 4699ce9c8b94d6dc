"""Map analysis (ALGORITHM.md §1-2): gates, tight tunnels, sealing, the clean field, the wave."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import planner
from planner.analysis.cells import TUNNEL
from tests import naive
from tests.conftest import grid_from

CORRIDOR = grid_from(
    """
    ........
    ........
    ###.####
    ........
    ........
    """
)


def test_one_cell_corridor_is_a_tunnel_and_sealed() -> None:
    a = planner.analyse(CORRIDOR)
    assert a.tunnels == 1
    assert a.state[2, 3] == TUNNEL
    assert a.passable()[2, 3] == 0
    assert a.passable(narrow=True)[2, 3] == 1
    assert a.sealed == 1
    assert planner.analyse(CORRIDOR, seal_tunnels=False).sealed == 0


def test_sealed_corridor_forces_the_narrow_fallback() -> None:
    p = planner.plan(CORRIDOR, [0, 3], [4, 3])
    assert p.narrow_fallback
    assert [2, 3] in p.path.tolist()
    with pytest.raises(planner.NoValidPath, match=r"NO_VALID_PATH.*tight tunnels"):
        planner.plan(CORRIDOR, [0, 3], [4, 3], allow_narrow=False)


def test_start_and_goal_are_never_sealed() -> None:
    # The start and goal are themselves tunnel cells, each at a corridor's mouth.
    grid = grid_from(
        """
        #.#####
        #.....#
        #####.#
        """
    )
    p = planner.plan(grid, [0, 1], [2, 5], preset="wide")
    assert p.path[0].tolist() == [0, 1]
    assert p.path[-1].tolist() == [2, 5]
    assert p.narrow_fallback  # the corridor between them is sealed


def test_diagonal_gap_is_a_gate_and_never_crossed() -> None:
    # Two walls that meet only at a corner: (2, 2) and (3, 3) are diagonal neighbours whose two
    # shared cells (2, 3) and (3, 2) are blocked. The way round is open
    # along the top and the right side.
    grid = grid_from(
        """
        ......
        ...#..
        ...#..
        ###...
        ......
        """
    )
    a = planner.analyse(grid)
    assert a.gates == 1
    assert a.gate_cells().tolist() == [[2, 2, 3, 3]]
    for preset in planner.PRESETS:
        p = planner.plan(grid, [0, 0], [4, 0], preset=preset)
        cells = [tuple(c) for c in p.path.tolist()]
        crossed = any({a_, b_} == {(2, 2), (3, 3)} for a_, b_ in itertools.pairwise(cells))
        assert not crossed, preset
    with pytest.raises(planner.NoValidPath):
        planner.plan(grid_from("#.\n.#"), [0, 1], [1, 0], preset="shortest")


def test_clean_in_the_open_at_corners_and_at_the_border() -> None:
    grid = np.zeros((7, 7), dtype=np.uint8)
    grid[3, 3] = 1
    a = planner.analyse(grid, clean_weight=0.5, clean_radius=1)
    assert a.clean[1, 1] == 0.0  # open: no blocked neighbour
    assert a.clean[2, 2] == 0.5  # diagonal to the obstacle
    assert a.clean[2, 3] == 0.5  # beside it
    assert a.clean[0, 3] == 1.5  # on the border: three outside cells
    assert a.clean[0, 0] == 2.5  # in the map's corner: five outside cells
    assert a.clean[3, 3] == 0.0  # obstacles carry no clean
    big = np.zeros((9, 9), dtype=np.uint8)
    big[4, 4] = 1
    r2 = planner.analyse(big, clean_weight=0.5, clean_radius=2)
    assert r2.clean[2, 2] == pytest.approx(0.5 / 2)  # the obstacle is two cells away
    assert r2.clean[3, 4] == pytest.approx(0.5)
    # The map's corner: 5 outside cells at distance 1, 11 at distance 2.
    assert r2.clean[0, 0] == pytest.approx(0.5 * 5 + 0.5 / 2 * 11)


def test_clean_counts_sealed_cells_as_blocked() -> None:
    sealed = planner.analyse(CORRIDOR, clean_radius=1)
    open_ = planner.analyse(CORRIDOR, clean_radius=1, seal_tunnels=False)
    assert sealed.clean[1, 3] == open_.clean[1, 3] + 0.5


@pytest.mark.parametrize("seed", range(40))
def test_kernels_match_the_naive_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    H, W = rng.integers(1, 14, size=2)
    grid = (rng.random((H, W)) < rng.uniform(0.0, 0.45)).astype(np.uint8)
    state, gates, tunnels = naive.classify(grid)
    seal = bool(seed % 2)
    radius = 1 + seed % 3
    weight = [0.5, 1.0, 0.25][seed % 3]
    a = planner.analyse(grid, seal_tunnels=seal, clean_weight=weight, clean_radius=radius)
    assert (a.state == state).all()
    assert (a.gates, a.tunnels) == (gates, tunnels)
    np.testing.assert_allclose(a.clean, naive.clean(state, seal, weight, radius), rtol=1e-6)
    free = np.argwhere(grid == 0)
    if len(free) == 0:
        return
    i = int(rng.integers(len(free)))
    goal = (int(free[i, 0]), int(free[i, 1]))
    diagonal = [math.sqrt(2), 1.4, 1.0, 2.0][seed % 4]
    for narrow in (False, True):
        w = planner.goal_wave(a, goal, diagonal_cost=diagonal, narrow=narrow)
        passable = a.passable(narrow=narrow)
        passable[goal] = 1
        np.testing.assert_allclose(w.k, naive.wave(passable, goal, diagonal, None), rtol=1e-12)
        np.testing.assert_allclose(w.kw, naive.wave(passable, goal, diagonal, a.clean), rtol=1e-9)


def test_wave_is_exact_on_an_open_grid() -> None:
    a = planner.analyse(np.zeros((5, 9), dtype=np.uint8), seal_tunnels=False, clean_weight=0)
    w = planner.goal_wave(a, (0, 0))
    rows, cols = np.indices((5, 9))
    octile = np.maximum(rows, cols) + (math.sqrt(2) - 1) * np.minimum(rows, cols)
    np.testing.assert_allclose(w.k, octile)
    assert w.kw is w.k  # no clean: one field serves both


def test_tau_is_the_clamped_pheromone() -> None:
    a = planner.analyse(np.zeros((1, 400), dtype=np.uint8), seal_tunnels=False, clean_weight=0)
    tau = planner.goal_wave(a, (0, 0)).tau(0.98, tau_min=0.01, tau_max=1.0)
    assert tau[0, 0] == 1.0
    assert tau[0, 10] == pytest.approx(0.98**10)
    assert tau[0, 399] == 0.01


def test_bad_goal_is_named() -> None:
    a = planner.analyse(CORRIDOR)
    with pytest.raises(planner.InvalidInput, match=r"goal \[2, 0\] is on an obstacle"):
        planner.goal_wave(a, (2, 0))
    with pytest.raises(planner.InvalidInput, match=r"goal \[9, 9\] is outside the 5 x 8 map"):
        planner.goal_wave(a, (9, 9))


def test_a_wave_whose_front_outgrows_its_first_pool_stays_exact() -> None:
    """A goal in the middle of a 400 x 400 grid: the front (~1,600 cells, some queued twice)
    outgrows the bucket queue's first pool of 1,024 entries, which grows as the wave goes on."""
    rng = np.random.default_rng(7)
    grid = (rng.random((400, 400)) < 0.05).astype(np.uint8)
    grid[200, 200] = 0
    a = planner.analyse(grid, seal_tunnels=False, clean_weight=2.0)
    w = planner.goal_wave(a, (200, 200))
    passable = a.passable(narrow=False)
    passable[200, 200] = 1
    np.testing.assert_allclose(w.k, naive.wave(passable, (200, 200), math.sqrt(2), None))
    np.testing.assert_allclose(w.kw, naive.wave(passable, (200, 200), math.sqrt(2), a.clean))

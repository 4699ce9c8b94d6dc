"""The kernels that the analysis tests do not reach, each against its slow reference in
``tests/naive.py`` on random grids (the clean field and the wave: ``test_analysis.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import planner
from planner.analysis.cells import classify, gate_cells
from planner.plans.decide import cost_here, legal_moves
from planner.plans.whole_wave import WaveView, _move_masks
from planner.stepping.simulation import move_obstacles
from tests import naive


def random_grid(seed: int, density: float | None = None) -> np.ndarray:
    rng = np.random.default_rng(seed)
    H, W = rng.integers(1, 12, size=2)
    p = rng.uniform(0.0, 0.5) if density is None else density
    return (rng.random((H, W)) < p).astype(np.uint8)


@pytest.mark.parametrize("seed", range(30))
def test_gate_cells(seed: int) -> None:
    grid = random_grid(seed)
    got = {frozenset({(r1, c1), (r2, c2)}) for r1, c1, r2, c2 in gate_cells(grid).tolist()}
    assert got == naive.gate_cells(grid)
    assert len(got) == classify(grid)[1]  # the analysis counts the same gates


@pytest.mark.parametrize("seed", range(30))
def test_move_masks_and_legal_moves(seed: int) -> None:
    passable = 1 - random_grid(seed)
    masks = _move_masks(passable)
    rng = np.random.default_rng(seed)
    H, W = passable.shape
    for r in range(H):
        for c in range(W):
            legal = naive.legal_moves(passable, r, c, set())
            assert masks[r, c] == (legal if passable[r, c] else 0)
            assert legal_moves(passable, r, c, 0) == legal
            dynamic = {(r + dr, c + dc) for dr, dc in naive.MOVES if rng.random() < 0.3}
            bits = sum(
                1 << i for i, (dr, dc) in enumerate(naive.MOVES) if (r + dr, c + dc) in dynamic
            )
            assert legal_moves(passable, r, c, bits) == naive.legal_moves(passable, r, c, dynamic)


@pytest.mark.parametrize("seed", range(30))
def test_cost_here(seed: int) -> None:
    rng = np.random.default_rng(seed)
    passable = 1 - random_grid(seed)
    field = np.where(rng.random(passable.shape) < 0.2, np.inf, rng.random(passable.shape) * 20)
    clean = rng.random(passable.shape).astype(np.float32)
    diagonal = [math.sqrt(2), 1.4][seed % 2]
    for r, c in np.ndindex(passable.shape):
        want = naive.cost_here(passable, field, np.zeros_like(clean), r, c, diagonal)
        view = WaveView(passable, field, field, clean, 0, 0)
        got = cost_here(view, (r, c), diagonal_cost=diagonal, use_clean=False)
        assert got == pytest.approx(want)
        want = naive.cost_here(passable, field, clean, r, c, diagonal)
        got = cost_here(view, (r, c), diagonal_cost=diagonal, use_clean=True)
        assert got == pytest.approx(want, rel=1e-6)


@pytest.mark.parametrize("seed", range(30))
def test_move_obstacles(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = random_grid(seed, density=0.25)
    free = [tuple(map(int, cell)) for cell in np.argwhere(grid == 0)]
    if len(free) < 2:
        return
    picks = rng.choice(len(free), size=min(len(free), 1 + seed % 6), replace=False)
    robot, cells = free[picks[0]], [free[i] for i in picks[1:]]
    obstacles = np.array(cells, dtype=np.int64).reshape(-1, 2)
    occupied = np.zeros(grid.shape, dtype=np.int32)
    for cell in cells:
        occupied[cell] += 1
    for _ in range(5):
        u = rng.random(len(cells))
        want = naive.move_obstacles(grid, cells, robot, u.tolist())
        move_obstacles(grid, occupied, obstacles, robot, u)
        cells = [tuple(map(int, cell)) for cell in obstacles]
        assert cells == want
        assert occupied.sum() == len(cells)
        assert all(occupied[cell] == 1 for cell in cells)


@pytest.mark.parametrize("seed", range(40))
def test_walk_follows_the_naive_decision_to_the_goal(seed: int) -> None:
    """``Plan.path`` (the walk kernel) is the naive decision applied step by step."""
    grid = random_grid(seed, density=0.2)
    free = [tuple(map(int, cell)) for cell in np.argwhere(grid == 0)]
    if len(free) < 2:
        return
    rng = np.random.default_rng(seed)
    start, goal = (free[i] for i in rng.choice(len(free), size=2, replace=False))
    preset = ["wide", "wfs-mmas", "mmas", "shortest"][seed % 4]
    try:
        p = planner.plan(grid, start, goal, preset=preset)
    except planner.NoValidPath:
        return
    w, a, params = p.wave, p.analysis, p.params
    want = naive.walk(
        np.asarray(w.passable), np.asarray(w.k), np.asarray(w.kw), np.asarray(a.clean),
        start, goal, params.decision == "paper", params.alpha, params.beta, params.diagonal_cost,
    )  # fmt: skip
    assert [tuple(cell) for cell in p.path.tolist()] == want

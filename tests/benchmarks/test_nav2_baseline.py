"""The Nav2-style baseline of ``benchmarks/nav2_baseline.py`` against a textbook Dijkstra."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import planner
from tests import naive
from tests.scripts import load_benchmark

BASELINE = load_benchmark("nav2_baseline")


def path_cost(cost: np.ndarray, path: np.ndarray) -> float:
    total = 0.0
    for a, b in zip(path[:-1].tolist(), path[1:].tolist(), strict=True):
        diagonal = a[0] != b[0] and a[1] != b[1]
        total += (50.0 + 0.8 * cost[b[0], b[1]]) * (math.sqrt(2.0) if diagonal else 1.0)
    return total


@given(st.integers(0, 2**32 - 1), st.integers(2, 12), st.integers(2, 12))
def test_the_baseline_is_an_exact_dijkstra(seed: int, H: int, W: int) -> None:
    rng = np.random.default_rng(seed)
    grid = (rng.random((H, W)) < 0.25).astype(np.int8)
    robot_map = planner.grid_map(grid, resolution=0.05)
    cs = planner.configuration_space(robot_map, robot_radius=0.04)
    cost = BASELINE.inflation_cost(cs)
    cells = np.argwhere(np.isfinite(cost))
    if len(cells) < 2:
        return
    i, j = rng.integers(len(cells), size=2)
    s = (int(cells[i, 0]), int(cells[i, 1]))
    g = (int(cells[j, 0]), int(cells[j, 1]))
    want = naive.nav2_cost(cost, s, g)
    path = BASELINE.nav2_path(cost, s, g)
    if not math.isfinite(want):
        assert path.size == 0
        return
    assert path[0].tolist() == list(s)
    assert path[-1].tolist() == list(g)
    passable = np.isfinite(cost)
    for a, b in zip(path[:-1].tolist(), path[1:].tolist(), strict=True):
        assert naive.legal(passable, a[0], a[1], b[0] - a[0], b[1] - a[1])
    assert math.isclose(path_cost(cost, path), want, rel_tol=1e-9)


def test_the_inflation_cost_is_nav2s() -> None:
    robot_map = planner.grid_map([[1] + [0] * 20], resolution=0.05)
    cs = planner.configuration_space(robot_map, robot_radius=0.22, unknown="free")
    cost = BASELINE.inflation_cost(cs)
    for c in range(21):
        d = c * 0.05
        if d <= 0.22 + 1e-9:
            assert cost[0, c] == math.inf
        elif d <= 0.55 + 1e-9:
            assert math.isclose(cost[0, c], 252 * math.exp(-3.0 * (d - 0.22)), rel_tol=1e-5)
        else:
            assert cost[0, c] == 0

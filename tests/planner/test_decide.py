"""The stepping kernels against the slow references of ``tests/naive.py``: the decision of one
step (both decisions, margins, tabu lists, detour targets, evading) and the replan's A*."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import planner
from planner.analysis.cells import BLOCKED_CELL
from planner.plans import decide as D
from tests import naive

OUTCOMES = {D.MOVE: "move", D.EVADE: "evade", D.WAIT: "wait", D.BLOCKED: "blocked"}


def random_case(seed: int) -> tuple[planner.Plan, np.random.Generator]:
    rng = np.random.default_rng(seed)
    H, W = (int(v) for v in rng.integers(5, 12, size=2))
    grid = (rng.random((H, W)) < rng.uniform(0.05, 0.35)).astype(np.uint8)
    free = np.argwhere(grid == 0)
    gr, gc = (int(v) for v in free[rng.integers(len(free))])
    goal = (gr, gc)
    preset = ("wide", "wfs-mmas", "mmas", "shortest")[seed % 4]
    # The analysis and waves of a plan from the goal to itself: every cell's fields.
    return planner.plan(grid, goal, goal, preset=preset), rng


@pytest.mark.parametrize("seed", range(40))
def test_decide_matches_the_naive_rules(seed: int) -> None:
    p, rng = random_case(seed)
    a, w = p.analysis, p.wave
    H, W = a.shape
    free = np.argwhere(a.state != BLOCKED_CELL)
    for _ in range(60):
        r, c = (int(v) for v in free[rng.integers(len(free))])
        m = int(rng.integers(0, 6))
        obstacles = free[rng.integers(len(free), size=m)].astype(np.int64)
        if rng.random() < 0.3:  # an obstacle on the robot's own cell
            obstacles = np.vstack([obstacles, [[r, c]]]).astype(np.int64)
        margin = int(rng.integers(0, 3))
        tabu_cells = {(r + dr, c + dc) for dr, dc in naive.MOVES if rng.random() < 0.3}
        tabu = sum(
            1 << i for i, (dr, dc) in enumerate(naive.MOVES) if (r + dr, c + dc) in tabu_cells
        )
        target = None
        if rng.random() < 0.3:
            dr, dc = naive.MOVES[int(rng.integers(8))]
            if 0 <= r + dr < H and 0 <= c + dc < W:
                target = (r + dr, c + dc)
        paper = p.params.decision == "paper"
        got = D.decide(
            w.view(r, c, a.clean), (r, c), D.Rule.of(p.params), np.ascontiguousarray(obstacles),
            goal=p.goal, margin=margin, tabu=tabu, target=target,
        )  # fmt: skip
        want = naive.decide(
            w.passable, w.k, w.kw, a.clean, (r, c), [(int(o[0]), int(o[1])) for o in obstacles],
            margin, tabu_cells, p.goal, paper, p.params.alpha, p.params.beta,
            p.params.diagonal_cost, target,
        )  # fmt: skip
        assert (int(got[0]), OUTCOMES[int(got[1])]) == want, (r, c, obstacles.tolist(), margin)


@pytest.mark.parametrize("seed", range(40))
def test_detour_is_an_optimal_legal_way_round_the_obstacles(seed: int) -> None:
    p, rng = random_case(seed)
    a, w = p.analysis, p.wave
    free = np.argwhere(a.state != BLOCKED_CELL)
    for _ in range(10):
        sr, sc = (int(v) for v in free[rng.integers(len(free))])
        start = (sr, sc)
        m = int(rng.integers(0, 5))
        obstacles = [(int(o[0]), int(o[1])) for o in free[rng.integers(len(free), size=m)]]
        margin = int(rng.integers(0, 3))
        for narrow in (False, True):
            cells = planner.detour(p, start, obstacles, margin=margin, narrow=narrow)
            passable = a.passable(narrow=True) if narrow else w.passable
            want = naive.detour_cost(
                passable, a.clean, start, p.goal, p.params.diagonal_cost, obstacles, margin
            )
            if want == math.inf or start == p.goal:
                assert cells.shape == (0, 2)
                continue
            route = [start, *map(tuple, cells.tolist())]
            assert route[-1] == p.goal
            cost = 0.0
            for (r, c), (nr, nc) in itertools.pairwise(route):
                dr, dc = nr - r, nc - c
                assert naive.legal(passable, r, c, dr, dc)
                assert all(naive.chebyshev((nr, nc), o) > margin for o in obstacles)
                cost += (p.params.diagonal_cost if dr and dc else 1.0) + float(a.clean[nr, nc])
            assert cost == pytest.approx(want, rel=1e-9)


def test_detour_validates_its_inputs() -> None:
    p = planner.plan(np.zeros((3, 3), dtype=np.uint8), (0, 0), (2, 2))
    with pytest.raises(planner.InvalidInput, match=r"cell \[5, 0\] is outside the 3 x 3 map"):
        planner.detour(p, [5, 0])
    with pytest.raises(planner.InvalidInput, match="margin must be an integer in"):
        planner.detour(p, [0, 0], margin=-1)
    with pytest.raises(planner.InvalidInput, match="dynamic_obstacles"):
        planner.detour(p, [0, 0], [[9, 9]])

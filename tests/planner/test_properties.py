"""Properties on random grids, for every preset: legal moves, the goal reached exactly when it is
reachable, ``wide`` never revisiting a cell, the session never entering a reported cell."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import planner
from tests import naive

Case = tuple[np.ndarray, tuple[int, int], tuple[int, int]]


@st.composite
def maps(draw: st.DrawFn) -> Case:
    h = draw(st.integers(1, 14))
    w = draw(st.integers(1, 14))
    density = draw(st.sampled_from([0.0, 0.15, 0.3, 0.45]))
    seed = draw(st.integers(0, 2**32 - 1))
    grid = (np.random.default_rng(seed).random((h, w)) < density).astype(np.uint8)
    start = (draw(st.integers(0, h - 1)), draw(st.integers(0, w - 1)))
    goal = (draw(st.integers(0, h - 1)), draw(st.integers(0, w - 1)))
    grid[start] = 0
    grid[goal] = 0
    return grid, start, goal


def assert_legal(path: np.ndarray, passable: np.ndarray) -> None:
    for (r, c), (nr, nc) in itertools.pairwise(path):
        dr, dc = int(nr - r), int(nc - c)
        assert max(abs(dr), abs(dc)) == 1, "not a move to a neighbour"
        assert naive.legal(passable, int(r), int(c), dr, dc), f"illegal move {r, c} -> {nr, nc}"


@given(maps(), st.sampled_from(sorted(planner.PRESETS)))
def test_plans_are_legal_and_complete(case: Case, preset: str) -> None:
    grid, start, goal = case
    reachable = naive.reachable(1 - grid, start, goal)
    try:
        p = planner.plan(grid, start, goal, preset=preset)
    except planner.NoValidPath:
        assert not reachable
        return
    assert reachable
    assert p.path[0].tolist() == list(start)
    assert p.path[-1].tolist() == list(goal)
    # Sealed cells are entered only under the narrow fallback (start and goal are never sealed).
    passable = p.analysis.passable(narrow=p.narrow_fallback).copy()
    passable[goal] = 1
    passable[start] = 1
    assert_legal(p.path, passable)
    if p.params.decision == "wide":
        cells = [tuple(c) for c in p.path.tolist()]
        assert len(set(cells)) == len(cells), "wide revisited a cell"
        assert np.all(np.diff(p.wave.kw[p.path[1:, 0], p.path[1:, 1]]) < 0)
    if preset == "shortest":
        assert abs(p.length - naive.wave(1 - grid, goal, 2**0.5, None)[start]) < 1e-9


@given(maps(), st.sampled_from(sorted(planner.PRESETS)), st.integers(0, 2**16))
def test_session_never_enters_a_reported_cell(case: Case, preset: str, seed: int) -> None:
    grid, start, goal = case
    try:
        p = planner.plan(grid, start, goal, preset=preset, patience=1)
    except planner.NoValidPath:
        return
    rng = np.random.default_rng(seed)
    session = planner.Session(p)
    # Sealed cells too: a robot held up takes the narrow way when the wide one is blocked, and
    # says so (narrow_fallback); a reported cell, never.
    passable = p.analysis.passable(narrow=True)
    sealed = np.asarray(p.wave.passable) == 0
    free = np.argwhere(grid == 0)
    for _ in range(60):
        obstacles = free[rng.random(len(free)) < 0.15]
        prev = session.state.position
        step = session.step(obstacles)
        blocked = passable.copy()
        blocked[obstacles[:, 0], obstacles[:, 1]] = 0
        if step.move == "WAIT":
            assert step.position == prev
        else:
            assert_legal(np.array([prev, step.position]), blocked)
            if sealed[step.position]:
                assert step.narrow_fallback, f"into sealed {step.position} without saying so"
        if step.status in ("arrived", "blocked"):
            break

"""The resumable goal wave (``planner.plans.resumable_wave``) against the whole-map wave and the
naive Dijkstra: exact values wherever a decision reads, the same plans and the same sessions
(strays and dynamic obstacles included), the same paths wherever no tie allowed another."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import planner
from planner.analysis.cells import FREE, TUNNEL
from planner.plans.decide import cost_here
from planner.plans.moves import OPEN_UNSEALED
from planner.plans.resumable_wave import ResumableWave, resumable_wave
from planner.plans.search import SETTLED_COUNT, GoalSearch
from tests import naive

Case = tuple[np.ndarray, tuple[int, int], tuple[int, int]]
SQRT2 = 2**0.5


@st.composite
def maps(draw: st.DrawFn, most: int = 70) -> Case:
    """Grids up to ``most`` cells a side: several 32 x 32 tiles of the search's memory."""
    h = draw(st.integers(1, most))
    w = draw(st.integers(1, most))
    density = draw(st.sampled_from([0.0, 0.1, 0.2, 0.35]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    grid = (rng.random((h, w)) < density).astype(np.uint8)
    start = (draw(st.integers(0, h - 1)), draw(st.integers(0, w - 1)))
    goal = (draw(st.integers(0, h - 1)), draw(st.integers(0, w - 1)))
    grid[start] = 0
    grid[goal] = 0
    return grid, start, goal


@given(
    maps(),
    st.sampled_from(sorted(planner.PRESETS)),
    st.booleans(),
    st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=6),
)
def test_settled_values_are_the_naive_wave(
    case: Case, preset: str, narrow: bool, robots: list[tuple[float, float]]
) -> None:
    grid, _, goal = case
    p = planner.resolve_params(preset)
    a = planner.analyse(
        grid, seal_tunnels=p.seal_tunnels, clean_weight=p.clean_weight, clean_radius=p.clean_radius
    )
    w = resumable_wave(a, goal, diagonal_cost=p.diagonal_cost, narrow=narrow)
    passable = a.passable(narrow=narrow)
    passable[goal] = 1
    k = naive.wave(passable, goal, p.diagonal_cost, None)
    kw = naive.wave(passable, goal, p.diagonal_cost, a.clean)
    H, W = grid.shape
    for fr, fc in robots:  # the robot strays anywhere, one cell after another
        r, c = min(int(fr * H), H - 1), min(int(fc * W), W - 1)
        v = w.view(r, c, a.clean)
        assert w.resumable  # small maps never reach the budget
        for yr, yc in naive.neighbourhood(passable, r, c):
            lr, lc = yr - v.top, yc - v.left
            assert v.passable[lr, lc] == 1
            np.testing.assert_allclose(v.k[lr, lc], k[yr, yc], rtol=1e-12)
            np.testing.assert_allclose(v.kw[lr, lc], kw[yr, yc], rtol=1e-9)
            assert w.k_at(yr, yc) == pytest.approx(k[yr, yc], rel=1e-12)
        for dr in range(3):
            for dc in range(3):
                yr, yc = v.top + dr, v.left + dc
                inside = 0 <= yr < H and 0 <= yc < W
                assert v.passable[dr, dc] == (passable[yr, yc] if inside else 0)
                assert v.clean[dr, dc] == (a.clean[yr, yc] if inside else 0)
    # The whole-map fields, on demand, are the whole-map wave's.
    np.testing.assert_allclose(w.k, k, rtol=1e-12)
    np.testing.assert_allclose(w.kw, kw, rtol=1e-9)


def _settled(w: ResumableWave) -> tuple[np.ndarray, np.ndarray]:
    """The flat cells both searches have settled, and their ``k`` and ``kw`` there."""
    H, W = w.shape
    cells = np.arange(H * W, dtype=np.int64)
    k, kw = w._k_search.values(cells), w._kw_search.values(cells)
    return k, kw


@pytest.mark.parametrize("name", ["depot", "tb3_sandbox"])
def test_settled_values_are_the_whole_map_waves_to_the_bit(ros: Path, name: str) -> None:
    """On a robot map (metric wall term: costs that tie only up to rounding), whatever robots
    the search was aimed at, in whatever order: the very floats of the whole-map wave, so a
    shared wave's decisions never depend on its history."""
    m = planner.read_ros_map(ros / f"{name}.yaml")
    p = planner.resolve_params("wide", robot_radius=0.22)
    a = planner.analyse_map(m, p)
    free = np.argwhere(a.state == FREE)
    rng = np.random.default_rng(5)
    for goal in free[rng.integers(len(free), size=4)]:
        whole = planner.goal_wave(a, goal, diagonal_cost=p.diagonal_cost)
        w = resumable_wave(a, goal, diagonal_cost=p.diagonal_cost)
        w.budget = w.probe = a.state.size  # searched to anywhere, never handed over
        for r, c in free[rng.integers(len(free), size=6)]:
            w.ensure(int(r), int(c))
        assert w.resumable
        k, kw = _settled(w)
        assert np.isfinite(kw).sum() > 100
        for got, want in ((k, whole.k.ravel()), (kw, whole.kw.ravel())):
            seen = np.isfinite(got)
            np.testing.assert_array_equal(got[seen], want[seen])


def _tie(plan: planner.Plan, cell: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the decision at ``cell`` valued moves to ``a`` and ``b`` alike (whole fields):
    by the wide value, or by Eq. 3's for the paper decision (which falls back to the wide one
    when every feasible neighbour is tabu)."""
    w, p = plan.wave, plan.params
    clean = plan.analysis.clean.astype(np.float64)  # float32 + a Python float stays float32

    def wide(y: np.ndarray) -> float:
        step = p.diagonal_cost if abs(y - cell).sum() == 2 else 1.0
        return float(step + clean[y[0], y[1]] + w.kw[y[0], y[1]])

    def paper(y: np.ndarray) -> float:
        h = float(np.hypot(y[0] - plan.goal[0], y[1] - plan.goal[1]))
        return float((w.k[y[0], y[1]] + clean[y[0], y[1]]) ** p.alpha * h**p.beta)

    def same(f: Any) -> bool:
        va, vb = f(a), f(b)
        return bool(abs(va - vb) <= 1e-9 * max(1.0, abs(va)))

    return same(wide) or (p.decision == "paper" and same(paper))


@given(maps(), st.sampled_from(sorted(planner.PRESETS)))
def test_plans_match_the_whole_map_wave(case: Case, preset: str) -> None:
    grid, start, goal = case
    # Unbounded (max_detour 100): a bounded plan may stand on an analysis of its own weights.
    try:
        whole = planner.plan(grid, start, goal, preset=preset, whole=True, max_detour=100)
    except planner.NoValidPath:
        with pytest.raises(planner.NoValidPath):
            planner.plan(grid, start, goal, preset=preset, max_detour=100)
        return
    lazy = planner.plan(grid, start, goal, preset=preset, analysis=whole.analysis, max_detour=100)
    assert isinstance(lazy.wave, ResumableWave)
    assert lazy.narrow_fallback == whole.narrow_fallback
    path, ref = lazy.path, whole.path
    n = min(len(path), len(ref))
    diverge = next((i for i in range(n) if (path[i] != ref[i]).any()), None)
    if diverge is None:
        assert len(path) == len(ref)
        assert lazy.length == pytest.approx(whole.length, abs=1e-9)
        assert lazy.arc_cost == pytest.approx(whole.arc_cost, rel=1e-9, abs=1e-9)
    else:
        assert _tie(whole, ref[diverge - 1], path[diverge], ref[diverge])
    if lazy.params.decision == "wide":
        # Either way the path costs the optimum: kw at the start.
        clean = lazy.analysis.clean
        steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
        cost = np.where(steps == 2, lazy.params.diagonal_cost, 1.0)
        cost += clean[path[1:, 0], path[1:, 1]]
        view = whole.wave.view(start[0], start[1], clean)
        here = cost_here(view, start, diagonal_cost=lazy.params.diagonal_cost, use_clean=True)
        assert cost.sum() == pytest.approx(here, rel=1e-9, abs=1e-9)


def _cost(plan: planner.Plan, cells: list[Any]) -> float:
    """The wide cost of a chain of cells: each move's length plus the clean of the cell entered
    (cells as ``[row, col]`` or flat indices)."""
    W = plan.analysis.shape[1]
    rc = np.array([divmod(x, W) if isinstance(x, int) else x for x in cells])
    steps = np.abs(np.diff(rc, axis=0)).sum(axis=1)
    moves = np.where(steps == 2, plan.params.diagonal_cost, 1.0)
    return float((moves + plan.analysis.clean[rc[1:, 0], rc[1:, 1]]).sum())


@given(maps(most=40), st.sampled_from(sorted(planner.PRESETS)), st.integers(0, 2**16))
def test_sessions_match_the_whole_map_wave(case: Case, preset: str, seed: int) -> None:
    grid, start, goal = case
    # Unbounded (max_detour 100): a bounded plan may stand on an analysis of its own weights.
    try:
        whole = planner.plan(
            grid, start, goal, preset=preset, whole=True, patience=1, max_detour=100
        )
    except planner.NoValidPath:
        return
    lazy = planner.plan(
        grid, start, goal, preset=preset, analysis=whole.analysis, patience=1, max_detour=100
    )
    one, two = planner.Session(lazy), planner.Session(whole)
    rng = np.random.default_rng(seed)
    free = np.argwhere(grid == 0)
    for _ in range(40):
        obstacles = free[rng.random(len(free)) < 0.1]
        position = None
        if rng.random() < 0.15:  # the client says the robot is elsewhere: a stray
            position = free[rng.integers(len(free))].tolist()
        a = one.step(obstacles, position=position)
        b = two.step(obstacles, position=position)
        if a.position != b.position:
            prev = np.array(a.previous)
            if a.status == b.status == "replanned":  # two detours: of the same cost
                costs = [
                    _cost(whole, [step.previous, step.position, *session.state.detour])
                    for step, session in ((a, one), (b, two))
                ]
                assert costs[0] == pytest.approx(costs[1], rel=1e-9)
                return
            assert a.status == b.status == "moving", (a, b)
            assert _tie(whole, prev, np.array(a.position), np.array(b.position))
            return
        assert (a.move, a.status) == (b.move, b.status)
        if one.state.detour != two.state.detour:  # equal-cost detours through other cells
            costs = [_cost(whole, [s.state.position, *s.state.detour]) for s in (one, two)]
            assert costs[0] == pytest.approx(costs[1], rel=1e-9)
            return
        assert (a.remaining is None) == (b.remaining is None)
        if a.remaining is not None and b.remaining is not None:
            assert a.remaining == pytest.approx(b.remaining, rel=1e-9, abs=1e-12)
        assert a.arc_cost == pytest.approx(b.arc_cost, rel=1e-9, abs=1e-9)
        if a.status in ("arrived", "blocked"):
            break


def test_a_near_goal_settles_few_cells_on_a_large_map() -> None:
    rng = np.random.default_rng(1)
    grid = (rng.random((1024, 1024)) < 0.2).astype(np.uint8)
    start, goal = (500, 500), (530, 535)
    grid[start] = grid[goal] = 0
    a = planner.analyse(grid)
    p = planner.plan(None, start, goal, analysis=a)
    assert len(p.path) > 30
    assert isinstance(p.wave, ResumableWave)
    assert p.wave.resumable
    assert p.wave.settled_cells < 20_000
    assert p.wave.nbytes < 0.5 * grid.size  # bytes: the whole-map wave holds 17 a cell
    session = planner.Session(p)
    for _ in range(10):
        session.step([], position=(480, 470))  # a stray: the search resumes from there
    assert p.wave.resumable
    assert session.state.position != (480, 470)
    # Held up by obstacles on every cell closer to the goal: a detour, still without the
    # whole-map wave.
    # (dynamic_margin 0: with the default margin 1, this wall leaves the robot no legal move.)
    replanned = planner.Session(
        planner.plan(None, start, goal, analysis=a, patience=0, dynamic_margin=0)
    )
    r, c = start
    wall = [[r + dr, c + dc] for dr in (1, 2) for dc in (-2, -1, 0, 1, 2)]
    wall += [[r, c + 1], [r, c + 2]]
    step = replanned.step(wall)
    assert step.status == "replanned"
    assert isinstance(replanned.plan.wave, ResumableWave)
    assert replanned.plan.wave.resumable
    assert all(divmod(x, 1024) not in map(tuple, wall) for x in replanned.state.detour)


def test_a_route_through_64_waypoints_keeps_its_legs_waves_small() -> None:
    """Issue 36's M1: 64 waypoints spread over a free map, each leg a few hundred cells long.
    Each leg's search settles a few tens of thousands of cells; at a budget of 1/64 of the map
    most legs handed over to whole-map waves (17 bytes a cell each, all held until the route
    was built: +900 MB on a 1024 x 1024 map in the service)."""
    side = 512
    a = planner.analyse_map(
        planner.grid_map(np.zeros((side, side), dtype=np.uint8), resolution=0.05),
        planner.resolve_params("wide"),
    )
    through = np.random.default_rng(36).integers(0, side, (64, 2)).tolist()
    p = planner.plan(None, [0, 0], [side - 1] * 2, analysis=a, waypoints=through, bounded=False)
    assert p.route is not None
    assert len(p.route.legs) == 65
    waves = {id(leg.wave): leg.wave for leg in p.route.legs}.values()
    held = sum(w.nbytes for w in waves)
    whole = 17 * side * side
    handed_over = [w for w in waves if not (isinstance(w, ResumableWave) and w.resumable)]
    assert len(handed_over) <= 12  # 9 (46 at 1/64)
    assert held < 0.4 * len(waves) * whole, (held, len(waves) * whole)  # 0.27 (0.74 at 1/64)


def test_a_far_goal_hands_over_to_the_whole_map_wave() -> None:
    grid = np.zeros((200, 200), dtype=np.uint8)
    a = planner.analyse(grid, seal_tunnels=False, clean_weight=0.5, clean_radius=2)
    w = resumable_wave(a, (0, 0))
    w.budget = 500
    w.ensure(199, 199)
    assert not w.resumable
    assert w.k_at(199, 199) == pytest.approx(199 * SQRT2)
    np.testing.assert_array_equal(w.kw, planner.goal_wave(a, (0, 0)).kw)


def test_unreachable_cells_are_infinite() -> None:
    grid = np.array([[0, 1, 0], [1, 1, 0], [0, 0, 0]], dtype=np.uint8)
    a = planner.analyse(grid, seal_tunnels=False)
    w = resumable_wave(a, (0, 0))
    w.settle([[2, 2], [0, 2]])
    assert w.k_at(2, 2) == np.inf
    assert w.k_at(0, 0) == 0.0


def test_resumable_wave_validates_at_the_edge() -> None:
    a = planner.analyse(np.array([[0, 1], [0, 0]], dtype=np.uint8))
    with pytest.raises(planner.InvalidInput, match="outside"):
        resumable_wave(a, (2, 0))
    with pytest.raises(planner.InvalidInput, match="obstacle"):
        resumable_wave(a, (0, 1))
    with pytest.raises(planner.InvalidInput, match="diagonal_cost"):
        resumable_wave(a, (0, 0), diagonal_cost=3.0)
    with pytest.raises(planner.InvalidInput, match="outside"):
        resumable_wave(a, (0, 0)).settle([[5, 5]])


@pytest.mark.parametrize("margin", [0, 1, 2])
def test_detours_with_a_margin_cost_what_the_whole_map_waves_do(margin: int) -> None:
    rng = np.random.default_rng(margin)
    grid = (rng.random((96, 96)) < 0.2).astype(np.uint8)  # larger than the search's budget
    start, goal = (40, 40), (70, 75)
    grid[start] = grid[goal] = 0
    a = planner.analyse(grid)
    whole = planner.goal_wave(a, goal)
    W = grid.shape[1]
    free = np.argwhere(grid == 0)
    for _ in range(6):
        lazy = resumable_wave(a, goal)
        lazy.ensure(*start)
        obstacles = free[rng.random(len(free)) < 0.03]
        obstacles = obstacles[(np.abs(obstacles - start).max(axis=1) > margin)]
        got = lazy.detour(start[0] * W + start[1], obstacles, a.clean, margin)
        want = whole.detour(start[0] * W + start[1], obstacles, a.clean, margin)
        assert (got.size == 0) == (want.size == 0)
        if got.size:
            cells = [start, *(divmod(int(x), W) for x in got)]
            refs = [start, *(divmod(int(x), W) for x in want)]
            assert _wide_cost(a, cells) == pytest.approx(_wide_cost(a, refs), rel=1e-9)
            near = np.abs(np.array(cells[1:])[:, None, :] - obstacles[None]).max(axis=2)
            assert (near > margin).all()


def _wide_cost(a: planner.Analysis, cells: list[Any]) -> float:
    rc = np.array(cells)
    steps = np.abs(np.diff(rc, axis=0)).sum(axis=1)
    return float((np.where(steps == 2, SQRT2, 1.0) + a.clean[rc[1:, 0], rc[1:, 1]]).sum())


def test_robot_map_plans_are_resumable_and_follow_the_whole_map_waves_path(ros: Path) -> None:
    m = planner.read_ros_map(ros / "depot.yaml")
    p = planner.resolve_params("wide", robot_radius=0.22)
    a = planner.analyse_map(m, p)
    free = np.argwhere(a.state == FREE)
    rng = np.random.default_rng(2)
    planned = 0
    for _ in range(12):
        start, goal = (tuple(int(v) for v in x) for x in free[rng.integers(len(free), size=2)])
        try:
            whole = planner.plan(None, start, goal, analysis=a, whole=True, robot_radius=0.22)
        except planner.NoValidPath:
            continue
        lazy = planner.plan(m, start, goal, analysis=a, robot_radius=0.22)
        assert isinstance(lazy.wave, ResumableWave)
        assert lazy.path.tolist() == whole.path.tolist()
        assert lazy.arc_cost == whole.arc_cost
        planned += 1
    assert planned >= 6


def test_the_narrow_fallback_and_detour_keep_the_wave_resumable() -> None:
    grid = np.zeros((100, 100), dtype=np.uint8)
    grid[10, :] = 1
    grid[10, 50] = 0  # a tight tunnel, sealed: the rows above are a pocket of the plan's grid
    p = planner.plan(grid, (70, 20), (90, 80), dynamic_margin=0)
    assert isinstance(p.wave, ResumableWave)
    assert not p.narrow_fallback
    assert p.analysis.state[10, 50] == TUNNEL
    session = planner.Session(p)
    step = session.step([], position=(5, 50))  # in the pocket: searched out at once
    assert step.status == "replanned"
    assert step.narrow_fallback
    assert 10 * 100 + 50 in session.state.detour
    way = planner.detour(p, (5, 50), [[6, 50]], margin=0, narrow=True)
    assert way[-1].tolist() == [90, 80]
    assert [10, 50] in way.tolist()
    wide = planner.detour(p, (70, 20), [[71, 21]], margin=0)
    assert wide[-1].tolist() == [90, 80]
    assert p.wave.resumable


def _search_toward(grid: np.ndarray, aim: tuple[int, int]) -> tuple[GoalSearch, bool]:
    """A ``kw`` search from the corner (0, 0) toward ``aim``, checking its headway after 2,000
    cells with room for 100,000; whether it settled ``aim``."""
    a = planner.analyse(grid, seal_tunnels=False, clean_weight=0.5, clean_radius=2)
    search = GoalSearch(a, 0, open_=OPEN_UNSEALED, use_clean=True, diagonal_cost=SQRT2)
    target = np.array([aim[0] * grid.shape[1] + aim[1]], dtype=np.int64)
    return search, search.settle_paced(target, aim, 0.0, 2_000, 100_000)


def test_a_search_making_headway_goes_on_past_its_probe() -> None:
    """Open space, a target ~200 cells away: past the probe the front has covered much of the
    way, so the search goes on and settles the target (more than the probe's cells)."""
    search, done = _search_toward(np.zeros((300, 300), dtype=np.uint8), (200, 150))
    assert done
    assert search.meta[SETTLED_COUNT] > 2_000


def test_a_search_making_little_headway_stops_at_its_probe() -> None:
    """A wall across the way with its gap at the far end: the front fills the near side first,
    barely nearer the target, so the search stops at the probe (the whole-map wave takes over)
    instead of running on to its limit."""
    grid = np.zeros((300, 300), dtype=np.uint8)
    grid[20, :290] = 1
    search, done = _search_toward(grid, (290, 10))
    assert not done
    assert 2_000 <= search.meta[SETTLED_COUNT] < 2_100
    assert search.headway() * 100_000 < search.meta[SETTLED_COUNT]

"""Stepping among dynamic obstacles (ALGORITHM.md §4)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import planner
from planner.stepping.obstacles import obstacle_cells
from tests.conftest import grid_from

# Two routes from (3, 0) to (3, 11): the straight one-cell corridor in row 3, and a longer one
# round the top or bottom.
TWO_ROUTES = grid_from(
    """
    ............
    .##########.
    .##########.
    ............
    .##########.
    .##########.
    ............
    """
)


def run(session: planner.Session, obstacles: list[list[int]], steps: int) -> list[planner.Step]:
    out = []
    for _ in range(steps):
        out.append(session.step(obstacles))
        if out[-1].status in ("arrived", "blocked"):
            break
    return out


@pytest.mark.parametrize("patience", [0, 1, 3, 5])
def test_detour_round_an_obstacle_parked_on_the_only_short_route(patience: int) -> None:
    p = planner.plan(TWO_ROUTES, (3, 0), (3, 11), preset="shortest", patience=patience)
    assert (p.path[:, 0] == 3).all()  # with no obstacle: straight through
    # The grid decision of ALGORITHM.md §4 (the paper's experiment): it waits `patience` steps.
    session = planner.Session(p, poses=False)
    parked = [[3, 6]]
    steps = run(session, parked, 60)
    assert steps[-1].status == "arrived"
    assert (3, 6) not in session.state.trajectory
    waits = [s for s in steps if s.status == "waiting"]
    assert len(waits) == patience
    replanned = [i for i, s in enumerate(steps) if s.status == "replanned"]
    assert len(replanned) == 1
    first_hold = next((i for i, s in enumerate(steps) if s.status == "waiting"), replanned[0])
    assert replanned[0] - first_hold <= patience + 1
    # Never looping: it backs out of the corridor once, and the detour repeats no cell.
    detour = session.state.trajectory[replanned[0] - len(waits) :]
    assert len(set(detour)) == len(detour)


# A corridor four cells wide between two long walls, and open space outside them.
CORRIDOR = np.zeros((14, 30), dtype=np.uint8)
CORRIDOR[4, 2:28] = 1
CORRIDOR[9, 2:28] = 1
ACROSS = [[r, 15] for r in range(5, 9)]  # obstacles parked across the corridor


def test_wide_detours_round_obstacles_across_a_wide_corridor() -> None:
    p = planner.plan(CORRIDOR, (6, 0), (6, 29), preset="wide", patience=2)
    assert (p.path[:, 0] == 6).all()  # the corridor's middle is the way
    # The grid decision of ALGORITHM.md §4 (the paper's experiment): it waits `patience` steps.
    session = planner.Session(p, poses=False)
    steps = run(session, ACROSS, 120)
    assert steps[-1].status == "arrived"
    assert not {tuple(c) for c in ACROSS} & set(session.state.trajectory)
    assert [s.status for s in steps].count("replanned") == 1
    assert [s.status for s in steps].count("waiting") == 2


def test_with_every_move_blocked_it_waits() -> None:
    grid = np.zeros((5, 5), dtype=np.uint8)
    p = planner.plan(grid, (2, 2), (0, 0), patience=1)
    session = planner.Session(p)
    ring = [[1, 1], [1, 2], [1, 3], [2, 1], [2, 3], [3, 1], [3, 2], [3, 3]]
    for _ in range(5):
        step = session.step(ring)
        assert (step.move, step.status, step.position) == ("WAIT", "waiting", (2, 2))
    assert session.state.waits == 5
    step = session.step([])
    assert step.status == "moving"
    assert step.move == "NW"


def test_it_steps_away_when_an_obstacle_enters_its_cell() -> None:
    grid = np.zeros((5, 5), dtype=np.uint8)
    p = planner.plan(grid, (2, 2), (0, 2))
    session = planner.Session(p)
    # Its way north is blocked, and an obstacle stands on its cell: it must not stay.
    step = session.step([[2, 2], [1, 1], [1, 2], [1, 3]])
    assert step.move != "WAIT"
    assert step.position not in {(2, 2), (1, 1), (1, 2), (1, 3)}


def test_diagonal_squeeze_between_dynamic_obstacles_is_refused() -> None:
    grid = np.zeros((3, 3), dtype=np.uint8)
    p = planner.plan(grid, (2, 0), (0, 2), preset="shortest", patience=100, dynamic_margin=0)
    session = planner.Session(p)
    step = session.step([[1, 0], [2, 1]])  # NE would pass between them
    assert step.move == "WAIT"
    step = session.step([[1, 0]])  # one orthogonal cell still occupied: no diagonal either
    assert step.move == "E"


def test_arrived_stays_arrived() -> None:
    p = planner.plan(np.zeros((1, 3), dtype=np.uint8), (0, 0), (0, 2))
    session = planner.Session(p)
    assert [session.step([]).status for _ in range(4)] == [
        "moving",
        "arrived",
        "arrived",
        "arrived",
    ]
    assert session.state.iteration == 2


def test_seq_retry_returns_the_same_answer_and_gaps_conflict() -> None:
    p = planner.plan(np.zeros((1, 6), dtype=np.uint8), (0, 0), (0, 5))
    session = planner.Session(p)
    first = session.step([], seq=7)  # the first step may take any seq
    assert first.position == (0, 1)
    assert session.step([[0, 2]], seq=7) == first  # a retry: same answer, not moved twice
    assert session.state.position == (0, 1)
    with pytest.raises(
        planner.SequenceConflict, match="seq 9 does not follow the last step's seq 7"
    ):
        session.step([], seq=9)
    with pytest.raises(planner.SequenceConflict):
        session.step([], seq=6)
    assert session.step([], seq=8).position == (0, 2)
    assert session.step([]).seq == 9  # no seq: the next one


def test_reported_position_overrides_the_recorded_one() -> None:
    p = planner.plan(np.zeros((5, 5), dtype=np.uint8), (0, 0), (4, 4))
    session = planner.Session(p)
    step = session.step([], position=[4, 2])
    assert step.previous == (4, 2)
    assert max(abs(step.position[0] - 4), abs(step.position[1] - 2)) == 1
    assert session.state.trajectory[:2] == [(0, 0), (4, 2)]
    with pytest.raises(planner.InvalidInput, match=r"position \[9, 9\] is outside the 5 x 5 map"):
        session.step([], position=[9, 9])


def test_blocked_when_the_goal_is_cut_off_statically() -> None:
    grid = grid_from(
        """
        ..#..
        ..#..
        ..#..
        """
    )
    p = planner.plan(grid, (0, 0), (2, 0))
    session = planner.Session(p)
    step = session.step([], position=[0, 4])
    assert step.status == "blocked"
    assert step.remaining is None


def test_bad_obstacles_are_named() -> None:
    p = planner.plan(np.zeros((3, 4), dtype=np.uint8), (0, 0), (2, 3))
    session = planner.Session(p)
    with pytest.raises(
        planner.InvalidInput, match=r"dynamic_obstacles\[1\] \[3, 0\] is outside the 3 x 4 map"
    ):
        session.step([[0, 1], [3, 0]])
    with pytest.raises(planner.InvalidInput, match="list of \\[row, col\\] cells"):
        session.step([[0, 1, 2]])
    with pytest.raises(planner.InvalidInput, match="list of \\[row, col\\] cells"):
        session.step([["a", "b"]])
    assert session.state.iteration == 0  # nothing was recorded


@pytest.mark.parametrize("seed", range(20))
def test_cells_given_as_an_array_are_checked_as_a_list_is(seed: int) -> None:
    # The array path (a fleet's steps) checks its cells in a kernel: the same first cell named.
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(1, 9)), int(rng.integers(1, 9)))
    cells = rng.integers(-2, 11, size=(int(rng.integers(0, 12)), 2))
    outside = [
        i
        for i, (r, c) in enumerate(cells.tolist())
        if not (0 <= r < shape[0] and 0 <= c < shape[1])
    ]
    for given in (cells, np.asfortranarray(cells), cells.tolist()):
        if not outside:
            got = obstacle_cells(given, shape)
            assert got.flags.c_contiguous
            assert got.dtype == np.int64
            assert got.reshape(-1, 2).tolist() == cells.tolist()
            continue
        i = outside[0]
        with pytest.raises(planner.InvalidInput, match=rf"dynamic_obstacles\[{i}\] "):
            obstacle_cells(given, shape)


def test_state_survives_a_json_round_trip() -> None:
    p = planner.plan(CORRIDOR, (6, 0), (6, 29), patience=2)
    a = planner.Session(p)
    wall = ACROSS
    for _ in range(20):
        a.step(wall)
    assert a.state.detour  # mid-detour: the hardest state to carry over
    b = planner.Session(
        p, planner.SessionState.from_dict(json.loads(json.dumps(a.state.as_dict())))
    )
    for _ in range(80):
        sa, sb = a.step(wall), b.step(wall)
        assert sa == sb
    assert b.state.as_dict() == a.state.as_dict()
    assert a.state.status == "arrived"


def test_may_replan_says_when_the_next_step_can_search() -> None:
    p = planner.plan(CORRIDOR, (6, 0), (6, 29), patience=2)
    # The grid decision of ALGORITHM.md §4 (the paper's experiment): it waits `patience` steps.
    session = planner.Session(p, poses=False)
    seen = []
    for _ in range(40):
        before = session.may_replan
        step = session.step(ACROSS)
        seen.append((before, step.status))
        if step.status == "replanned":
            break
    assert seen[-1] == (True, "replanned")
    # Only the held-up steps from the patience-th on may search; moving resets it.
    assert all(not before for before, status in seen[:-1] if status == "moving")
    assert [status for before, status in seen if before] == ["replanned"]
    assert not session.may_replan

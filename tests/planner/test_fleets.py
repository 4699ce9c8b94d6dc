"""The fleet rules' pieces (planner/fleets): the robots' disks against a brute-force reference,
the margin's erosion covering every cell of the disk, and passage zones that wait clear of a
passage's mouths without leaking through walls."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest

import planner
from planner.fleets import (
    NO_TRAFFIC,
    Robot,
    after_step,
    covering,
    robot_cells,
    traffic_for,
    wait_distance,
    waiting_zones,
)
from planner.fleets.waiting import WaitingZones
from tests import naive_fleets

WHOLE_CELLS = [(0.15, 0.1, 1), (0.2, 0.1, 0), (0.22, 0.05, 1), (0.325, 0.1, 2), (0.05, 0.1, 1)]
"""Radii (each robot's, meters), resolutions and margins whose disks end on whole cells."""


@pytest.mark.parametrize(("radius", "resolution", "margin"), [*WHOLE_CELLS, (0.0, 0.1, 0)])
def test_robot_cells_at_radii_on_whole_cells_match_the_reference(
    radius: float, resolution: float, margin: int
) -> None:
    """Radii whose squares land on whole cells (0.15 + 0.15 m at 0.1 m with a margin of 1:
    4.999999999999998 cells squared, the cell at 5 kept by the rounding) as the numpy
    reference gives them; near the edges, cell and target apart."""
    others = [
        Robot(0, (1, 1), (2, 2), radius, (0, 0)),
        Robot(1, (10, 12), (10, 12), radius, (0, 0)),
        Robot(2, (18, 0), (19, 0), radius, (0, 0)),
    ]
    got = robot_cells(radius, others, resolution=resolution, shape=(20, 14), margin=margin)
    want = naive_fleets.robot_cells(
        radius, others, resolution=resolution, shape=(20, 14), margin=margin
    )
    assert sorted(map(tuple, got.tolist())) == sorted(map(tuple, want.tolist()))


def _dilate(cells: set[tuple[int, int]], margin: int) -> set[tuple[int, int]]:
    span = range(-margin, margin + 1)
    return {(r + a, c + b) for r, c in cells for a, b in itertools.product(span, span)}


@pytest.mark.parametrize("margin", [1, 2, 3])
@pytest.mark.parametrize("radii", [(0.05, 0.05), (0.15, 0.15), (0.22, 0.3), (0.325, 0.325)])
def test_the_margin_grown_cells_cover_every_cell_within_both_radii(
    margin: int, radii: tuple[float, float]
) -> None:
    mine, theirs = radii
    other = Robot(0, (30, 30), (31, 32), theirs, (0, 0))
    given = robot_cells(mine, [other], resolution=0.05, shape=(64, 64), margin=margin)
    blocked = _dilate(set(map(tuple, given.tolist())), margin)
    reach = (mine + theirs) / 0.05
    for r, c in itertools.product(range(64), range(64)):
        near = min(math.hypot(r - 30, c - 30), math.hypot(r - 31, c - 32))
        if near <= reach:
            assert (r, c) in blocked, (r, c)
    # ... and it gives fewer cells than the whole disk.
    whole = robot_cells(mine, [other], resolution=0.05, shape=(64, 64))
    assert len(given) < len(whole)


def test_robot_cells_stay_inside_the_map_and_cover_cell_and_target() -> None:
    a = Robot(0, (0, 0), (1, 1), 0.05, (5, 5))
    cells = robot_cells(0.05, [a], resolution=0.1, shape=(4, 4))
    assert set(map(tuple, cells.tolist())) == {(0, 0), (0, 1), (1, 0), (1, 1), (1, 2), (2, 1)}


@pytest.mark.parametrize("seed", range(6))
def test_robot_cells_are_the_union_of_the_disks_about_each_cell_and_target(seed: int) -> None:
    """The kernel against brute force: several robots, near the map's edges, with and without
    a margin; every robot's cells once (a robot's two disks overlap)."""
    rng = np.random.default_rng(seed)
    shape, resolution, mine = (30, 40), 0.05, 0.2
    margin = int(rng.integers(0, 3))
    others = [
        Robot(i, (int(r), int(c)), (int(r + dr), int(c + dc)), float(radius), (0, 0))
        for i, (r, c, dr, dc, radius) in enumerate(
            zip(
                rng.integers(-2, 32, 8), rng.integers(-2, 42, 8), rng.integers(-1, 2, 8),
                rng.integers(-1, 2, 8), rng.uniform(0.0, 0.4, 8), strict=True,
            )
        )
    ]  # fmt: skip
    cells = robot_cells(mine, others, resolution=resolution, shape=shape, margin=margin)
    expected: list[tuple[int, int]] = []
    for o in others:
        reach = (mine + o.radius) / resolution
        if margin > 0:
            reach = 0.0 if reach <= margin else math.hypot(reach - margin, margin)
        expected += {
            (r, c)
            for r, c in itertools.product(range(shape[0]), range(shape[1]))
            if min(math.hypot(r - o.cell[0], c - o.cell[1]),
                   math.hypot(r - o.target[0], c - o.target[1])) <= reach + 1e-9
        }  # fmt: skip
    assert sorted(map(tuple, cells.tolist())) == sorted(expected)


def test_covering_lists_the_robots_touching_a_cell_by_rank() -> None:
    others = {
        "b": Robot(2, (10, 10), (10, 11), 0.2, (0, 0)),
        "a": Robot(1, (10, 14), (10, 14), 0.2, (0, 0)),
        "far": Robot(0, (40, 40), (40, 40), 0.2, (0, 0)),
    }
    assert covering((10, 12), 0.2, others, resolution=0.1) == ["a", "b"]
    assert covering((20, 20), 0.2, others, resolution=0.1) == []


def _corridor() -> planner.RobotMap:
    """Two rooms 4 m wide joined by a 0.8 m x 2 m corridor, 0.1 m cells; and behind the left
    room's right wall, nothing: the zone must not leak into the other room through it."""
    occ = np.full((42, 104), 100, dtype=np.int8)
    occ[1:41, 1:41] = 0
    occ[1:41, 63:103] = 0
    occ[17:25, 41:63] = 0
    return planner.RobotMap(occ, planner.MapFrame(occ.shape, 0.1, (0.0, 0.0, 0.0)))


RADIUS = 0.325
"""The corridor's robots (meters): its 0.8 m lane holds one at a time."""


def _corridor_zones() -> tuple[planner.RobotMap, WaitingZones]:
    """:func:`_corridor` and its passage's waiting zone for robots of :data:`RADIUS`."""
    m = _corridor()
    space = planner.configuration_space(m, robot_radius=RADIUS)
    passages = planner.find_passages(m, RADIUS)
    zones = waiting_zones(space.traversable, passages, resolution=0.1, robot_radius=RADIUS)
    return m, zones


def test_a_corridors_zone_reaches_the_waiting_distance_into_each_room_and_no_farther() -> None:
    m = _corridor()
    radius = 0.325
    space = planner.configuration_space(m, robot_radius=radius)
    passages = planner.find_passages(m, radius)
    assert len(passages) == 1
    zones = waiting_zones(space.traversable, passages, resolution=0.1, robot_radius=radius)
    assert zones.count == 1
    assert zones.passages == ((0,),)
    grid = zones.group.reshape(m.shape)
    inside = np.argwhere(grid == 0)
    neck = np.array(np.divmod(passages[0].cells, m.shape[1])).T
    reach = wait_distance(radius) / 0.1
    d = np.min(np.hypot(*(inside[:, None, :] - neck[None, :, :]).transpose(2, 0, 1)), axis=1)
    assert d.max() <= reach + 1e-9
    # It reaches about the waiting distance past both ends of the neck, on the corridor's axis.
    first, last = int(neck[:, 1].min()), int(neck[:, 1].max())
    assert first <= 41
    assert last >= 62
    assert grid[21, first - round(reach) + 1] == 0
    assert grid[21, last + round(reach) - 1] == 0
    assert grid[21, first - round(reach) - 2] == -1
    assert grid[21, last + round(reach) + 2] == -1
    # Only traversable cells, and only the corridor's side of the walls.
    assert (space.traversable[grid == 0] == 1).all()
    assert zones.group_at((5, 40)) == -1


def test_a_passage_held_by_one_robot_is_closed_to_the_others_but_the_waiter_of_rank_first() -> None:
    m, zones = _corridor_zones()
    inside, left, right = (21, 50), (21, 10), (21, 95)
    robots = {
        "holder": Robot(5, inside, inside, RADIUS, (21, 95)),
        "first": Robot(1, left, left, RADIUS, (21, 90), wants=0),
        "later": Robot(2, right, right, RADIUS, (21, 5)),
    }
    for k in ("first", "later"):
        traffic = traffic_for(k, robots, resolution=0.1, shape=m.shape, zones=zones)
        assert traffic.closed == {0: "holder"}
        assert len(traffic.zones) == int((zones.group == 0).sum())
    assert traffic_for("holder", robots, resolution=0.1, shape=m.shape, zones=zones).closed == {}
    # The holder gone: the passage is the first waiter's; closed to the later one for it.
    del robots["holder"]
    assert traffic_for("first", robots, resolution=0.1, shape=m.shape, zones=zones).closed == {}
    traffic = traffic_for("later", robots, resolution=0.1, shape=m.shape, zones=zones)
    assert traffic.closed == {0: "first"}
    # Waiting at it, the later robot waits for the robot it is closed for.
    after = after_step(
        robots["later"], previous=right, position=right, status="waiting", traffic=traffic,
        zones=zones, would_enter=0,
    )  # fmt: skip
    assert after.wants == 0
    assert after.waiting_for == "first"
    assert after.holds == ()
    moved = after_step(
        robots["first"], previous=(21, 40), position=(21, 41), status="moving",
        traffic=traffic, zones=zones,
    )  # fmt: skip
    assert moved.holds == (0,)
    assert moved.wants is None


def test_a_holder_leaving_the_passage_that_waits_for_a_robot_on_its_goal_hands_it_over() -> None:
    # The holder has come out of the corridor into the right room (still in the zone) and waits
    # for the robot standing on its goal, which waits for the passage behind a waiter ranked
    # first: that robot takes the holder's turn, ahead of it; the others still wait.
    m, zones = _corridor_zones()
    out, goal = (21, 78), (21, 88)
    assert zones.group_at(out) == 0
    assert zones.group_at(goal) == -1
    holder = Robot(2, out, out, RADIUS, goal, status="waiting", waiting_for="on goal", leaving=0)
    robots = {
        "holder": holder,
        "on goal": Robot(3, goal, goal, RADIUS, (21, 5), status="waiting", wants=0),
        "first": Robot(0, (30, 90), (30, 90), RADIUS, (21, 5), status="waiting", wants=0),
        "left": Robot(1, (21, 10), (21, 10), RADIUS, (21, 95), status="waiting", wants=0),
    }
    kw: dict[str, Any] = {"resolution": 0.1, "shape": m.shape, "zones": zones}
    assert traffic_for("on goal", robots, **kw).closed == {}
    assert traffic_for("first", robots, **kw).closed == {0: "holder"}
    assert traffic_for("left", robots, **kw).closed == {0: "holder"}
    # Not yet through the neck (it would go in next), it keeps the passage from everyone.
    coming = {**robots, "holder": holder._replace(leaving=None)}
    assert traffic_for("on goal", coming, **kw).closed == {0: "holder"}
    # Another robot holding it too keeps it closed.
    also = Robot(4, (21, 45), (21, 45), RADIUS, (21, 95))
    assert traffic_for("on goal", {**robots, "also": also}, **kw).closed == {0: "also"}


def test_a_robot_is_leaving_a_passage_from_its_neck_until_it_is_out_of_its_zone() -> None:
    m, zones = _corridor_zones()
    row = 21
    zone = [c for c in range(m.shape[1]) if zones.group_at((row, c)) == 0]
    neck = [c for c in range(m.shape[1]) if zones.in_neck((row, c))]
    assert zone[0] < neck[0] < neck[-1] < zone[-1]
    robot = Robot(0, (row, 5), (row, 5), RADIUS, (row, 95))
    leaving = {}
    for c in range(6, 96):
        robot = after_step(
            robot, previous=robot.target, position=(row, c), status="moving", traffic=NO_TRAFFIC,
            zones=zones,
        )  # fmt: skip
        leaving[c] = robot.leaving
    # Into the zone and through the neck: not leaving; out of the neck, leaving until out of the
    # zone.
    assert {c for c, g in leaving.items() if g is not None} == set(
        range(neck[-1] + 1, zone[-1] + 1)
    )
    assert set(leaving.values()) == {None, 0}
    # Back into the neck: not leaving; reported elsewhere in the zone: not leaving.
    out = Robot(0, (row, neck[-1] + 2), (row, neck[-1] + 2), RADIUS, (row, 95), leaving=0)
    back = after_step(
        out, previous=out.target, position=(row, neck[-1]), status="moving", traffic=NO_TRAFFIC,
        zones=zones,
    )  # fmt: skip
    assert back.leaving is None
    elsewhere = after_step(
        out, previous=(row, zone[0]), position=(row, zone[0] + 1), status="moving",
        traffic=NO_TRAFFIC, zones=zones,
    )  # fmt: skip
    assert elsewhere.leaving is None
    # Standing where it was, it is leaving still.
    stays = after_step(
        out, previous=out.target, position=out.target, status="waiting", traffic=NO_TRAFFIC,
        zones=zones,
    )  # fmt: skip
    assert stays.leaving == 0


def test_passages_whose_zones_meet_are_one_group() -> None:
    # Two doors 0.6 m apart in one wall: a robot between them would block both.
    occ = np.full((42, 62), 100, dtype=np.int8)
    occ[1:41, 1:30] = 0
    occ[1:41, 32:61] = 0
    occ[12:20, 30:32] = 0
    occ[26:34, 30:32] = 0
    m = planner.RobotMap(occ, planner.MapFrame(occ.shape, 0.1, (0.0, 0.0, 0.0)))
    space = planner.configuration_space(m, robot_radius=0.3)
    passages = planner.find_passages(m, 0.3)
    assert len(passages) == 2
    zones = waiting_zones(space.traversable, passages, resolution=0.1, robot_radius=0.3)
    assert zones.passages == ((0, 1),)
    assert {zones.group_at((16, 31)), zones.group_at((30, 31))} == {0}


def test_no_passages_no_zones() -> None:
    space = np.ones((5, 5), dtype=np.uint8)
    zones = waiting_zones(space, [], resolution=1.0, robot_radius=0.0)
    assert zones.count == 0
    assert (zones.group == -1).all()


@pytest.mark.parametrize("seed", range(5))
def test_robots_on_the_goal_are_those_whose_blocked_cells_reach_it(seed: int) -> None:
    """``Traffic.on_goal`` against brute force: another robot is on the goal when the cells the
    step blocks for it (its cells given, grown by the margin) hold the goal, or when it is
    within the sum of both radii of the goal."""
    rng = np.random.default_rng(seed)
    shape, resolution, margin = (40, 40), 0.05, 1
    robots = {
        f"r{i}": Robot(
            i, (int(r), int(c)), (int(r) + int(dr), int(c) + int(dc)), float(radius), (0, 0)
        )
        for i, (r, c, dr, dc, radius) in enumerate(
            zip(
                rng.integers(2, 38, 12), rng.integers(2, 38, 12), rng.integers(-1, 2, 12),
                rng.integers(-1, 2, 12), rng.uniform(0.05, 0.3, 12), strict=True,
            )
        )
    }  # fmt: skip
    goal = (int(rng.integers(5, 35)), int(rng.integers(5, 35)))
    robots["me"] = Robot(99, (0, 0), (0, 0), 0.2, goal)
    traffic = traffic_for("me", robots, resolution=resolution, shape=shape, margin=margin)
    expected = []
    for k, other in robots.items():
        if k == "me":
            continue
        given = robot_cells(0.2, [other], resolution=resolution, shape=shape, margin=margin)
        grown = _dilate(set(map(tuple, given.tolist())), margin)
        if goal in grown or covering(goal, 0.2, {k: other}, resolution=resolution):
            expected.append(k)
    assert list(traffic.on_goal) == sorted(expected, key=lambda k: robots[k].rank)


@pytest.mark.parametrize("seed", range(4))
def test_traffic_matches_the_reference_on_random_fleets(seed: int) -> None:
    """The one-pass ``traffic_for`` against the reference (tests/naive_fleets.py) on random
    fleets: several passage groups, several holders and waiters, holders leaving and waiting for
    the robot, robots on the goal, margins 0 to 2, with and without ``within``
    and ``here``; the same cells (as a multiset), closed groups (in order, and for whom), zone
    cells and robots on the goal."""
    rng = np.random.default_rng(seed)
    for _ in range(60):
        H, W = int(rng.integers(5, 30)), int(rng.integers(5, 30))
        count = int(rng.integers(0, 4))
        group = rng.integers(-1, max(count, 1), H * W).astype(np.int32)
        group[(rng.random(H * W) < 0.6) | (count == 0)] = -1
        zones = WaitingZones((H, W), group, tuple((g,) for g in range(count)))
        robots = {}
        size = int(rng.integers(1, 8))
        for i, rank in enumerate(rng.permutation(20)[:size]):
            r, c = int(rng.integers(0, H)), int(rng.integers(0, W))
            target = (min(max(r + int(rng.integers(-1, 2)), 0), H - 1),
                      min(max(c + int(rng.integers(-1, 2)), 0), W - 1))  # fmt: skip
            goal = (int(rng.integers(0, H)), int(rng.integers(0, W)))
            radius = float(rng.choice([0.05, 0.1, 0.15, 0.2, 0.22, 0.325, rng.uniform(0, 0.4)]))
            wants = int(rng.integers(0, count)) if count and rng.random() < 0.4 else None
            waiting_for = f"p{rng.integers(0, size)}" if rng.random() < 0.4 else None
            leaving = zones.group_at(target) if rng.random() < 0.5 else None
            robots[f"p{i}"] = Robot(
                int(rank), (r, c), target, radius, goal, waiting_for=waiting_for, wants=wants,
                leaving=None if leaving == -1 else leaving,
            )  # fmt: skip
        kw: dict[str, Any] = {
            "resolution": float(rng.choice([0.05, 0.1, 0.25])), "shape": (H, W),
            "zones": zones, "margin": int(rng.integers(0, 3)),
            "within": None if rng.random() < 0.5 else int(rng.integers(0, 10)),
        }  # fmt: skip
        if rng.random() < 0.5:
            kw["here"] = (int(rng.integers(0, H)), int(rng.integers(0, W)))
        for plan_id in robots:
            got = traffic_for(plan_id, robots, **kw)
            cells, closed, zone_cells, on_goal = naive_fleets.traffic_for(plan_id, robots, **kw)
            assert sorted(map(tuple, got.robots.tolist())) == sorted(map(tuple, cells.tolist()))
            assert list(got.closed.items()) == list(closed.items())
            assert got.zones.tolist() == zone_cells.tolist()
            assert got.on_goal == on_goal


def test_a_robot_beside_a_waiting_robot_of_lower_priority_lets_it_search_first() -> None:
    # Ranks 0 (higher priority) and 1, 0.2 m robots on 0.1 m cells: 4 cells apart is within the
    # sum of radii, the margin and two cells.
    me = Robot(0, (10, 10), (10, 10), 0.2, (10, 30))
    beside = {"me": me, "o": Robot(1, (10, 14), (10, 14), 0.2, (10, 0), status="waiting")}
    kw: dict[str, Any] = {"resolution": 0.1, "shape": (20, 40), "margin": 1}
    assert traffic_for("me", beside, **kw).beside_waiter
    assert not traffic_for("o", beside, **kw).beside_waiter  # the other way round: it searches
    moving = {**beside, "o": beside["o"]._replace(status="moving")}
    assert not traffic_for("me", moving, **kw).beside_waiter
    far = {**beside, "o": beside["o"]._replace(cell=(10, 20), target=(10, 20))}
    assert not traffic_for("me", far, **kw).beside_waiter

"""Laser scans traced on a map (planner.live): the kernel against the exact reference of
``tests/naive_scans.py`` on random rays, and a scan's rules in meters (range_min, the robot's
own body, no return, the map's walls, a rotated frame)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from planner import InvalidInput, LaserScan, MapFrame, Traced, trace_scan
from planner.live.scans import trace_rays
from tests import naive_scans


def _sets(traced: Traced, shape: tuple[int, int]) -> tuple[set[int], set[int]]:
    W = shape[1]
    rows, cols = np.nonzero(traced.cleared)
    cleared = {int((r + traced.top) * W + c + traced.left) for r, c in zip(rows, cols, strict=True)}
    return set(traced.marked.tolist()), cleared


@pytest.mark.parametrize("seed", range(40))
def test_rays_match_the_exact_crossings(seed: int) -> None:
    rng = np.random.default_rng(seed)
    H, W = (int(v) for v in rng.integers(3, 30, size=2))
    blocked = rng.random((H, W)) < rng.uniform(0, 0.3)
    start = rng.uniform([0, 0], [W, H])
    n = int(rng.integers(1, 40))
    ends = start + rng.uniform(-1.5, 1.5, size=(n, 2)) * [W, H]
    ends = np.clip(ends, [-1, -1], [W + 1, H + 1])
    hits = rng.random(n) < 0.6
    traced = trace_rays(blocked, start, ends, hits)
    marked, cleared = _sets(traced, (H, W))
    # Exactly the squares the rays run inside, up to squares only grazed (a corner touched).
    ref_marked, sure = naive_scans.trace(blocked, start, ends, hits, least=1e-7)
    _, touched = naive_scans.trace(blocked, start, ends, hits, least=-1.0)
    assert marked == ref_marked
    assert sure <= cleared <= touched
    assert not (marked & cleared)
    assert not blocked.reshape(-1)[list(marked | cleared)].any()


def _scan(
    ranges: list[float | None],
    *,
    angle_min: float = -math.pi,
    increment: float | None = None,
    range_min: float = 0.1,
    range_max: float = 5.0,
) -> LaserScan:
    n = len(ranges)
    increment = 2 * math.pi / max(n, 1) if increment is None else increment
    values = np.array([math.nan if r is None else r for r in ranges], dtype=np.float64)
    return LaserScan(angle_min, increment, range_min, range_max, values)


def test_a_return_marks_its_cell_and_clears_the_ray_before_it() -> None:
    frame = MapFrame((20, 40), 0.1, (0.0, 0.0, 0.0))
    blocked = np.zeros(frame.shape, dtype=bool)
    scan = _scan([1.23], angle_min=0.0, increment=0.01)
    traced = trace_scan(frame, blocked, scan, (0.55, 1.05, 0.0))
    marked, cleared = _sets(traced, frame.shape)
    hit = frame.cells([[0.55 + 1.23, 1.05]])[0]
    assert marked == {int(hit[0] * 40 + hit[1])}
    row = int(hit[0])
    assert cleared == {row * 40 + c for c in range(5, int(hit[1]))}


def test_no_return_clears_to_range_max_and_marks_nothing() -> None:
    frame = MapFrame((20, 40), 0.1)
    blocked = np.zeros(frame.shape, dtype=bool)
    for value in (None, 5.0, 7.0):  # null, at range_max and beyond: no return
        traced = trace_scan(frame, blocked, _scan([value], angle_min=0.0), (0.05, 0.05, 0.0))
        marked, cleared = _sets(traced, frame.shape)
        assert marked == set()
        assert cleared == {19 * 40 + c for c in range(40)}  # to the map's edge (5 m > 4 m)


def test_short_returns_and_the_robots_own_body_are_ignored() -> None:
    frame = MapFrame((20, 40), 0.1)
    blocked = np.zeros(frame.shape, dtype=bool)
    pose = (2.0, 1.0, 0.0)
    too_close = trace_scan(frame, blocked, _scan([0.05], angle_min=0.0), pose)
    assert too_close.marked.size == 0
    assert not too_close.cleared.any()
    body = trace_scan(frame, blocked, _scan([0.25], angle_min=0.0), pose, robot_radius=0.3)
    assert body.marked.size == 0
    assert not body.cleared.any()
    beyond = trace_scan(frame, blocked, _scan([0.35], angle_min=0.0), pose, robot_radius=0.3)
    assert beyond.marked.size == 1


def test_walls_are_neither_marked_nor_cleared() -> None:
    frame = MapFrame((10, 10), 1.0)
    blocked = np.zeros(frame.shape, dtype=bool)
    blocked[:, 5] = True
    # A ray through the wall (as a glass wall lets it) and a return on the wall.
    scan = _scan([None, 4.5], angle_min=0.0, increment=0.0, range_max=20.0)
    rays = trace_scan(frame, blocked, scan, (0.5, 4.5, 0.0))
    marked, cleared = _sets(rays, frame.shape)
    assert marked == set()
    assert all(not blocked.reshape(-1)[f] for f in cleared)
    assert {5 * 10 + c for c in (0, 1, 2, 3, 4, 6, 7, 8, 9)} == cleared


def test_a_rotated_frame_marks_where_the_point_is() -> None:
    frame = MapFrame((30, 30), 0.1, (2.0, 3.0, 1.0))
    blocked = np.zeros(frame.shape, dtype=bool)
    sensor = frame.centers([[15, 15]])[0]
    rng = np.random.default_rng(3)
    for _ in range(20):
        angle, dist = rng.uniform(-math.pi, math.pi), rng.uniform(0.3, 1.2)
        scan = _scan([dist], angle_min=angle, increment=0.0)
        traced = trace_scan(frame, blocked, scan, (sensor[0], sensor[1], 0.0))
        point = sensor + dist * np.array([math.cos(angle), math.sin(angle)])
        r, c = frame.cells([point])[0]
        assert traced.marked.tolist() == [int(r) * 30 + int(c)]


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"range_min": 2.0, "range_max": 1.0}, "scan.range_min"),
        ({"increment": 0.1, "ranges": [1.0] * 100}, "scan.angle_increment"),
        ({"ranges": []}, "scan.ranges"),
        ({"ranges": [-1.0]}, "scan.ranges"),
        ({"range_max": math.inf}, "scan.range_max"),
    ],
)
def test_bad_scans_name_their_field(kwargs: dict[str, Any], field: str) -> None:
    ranges = kwargs.pop("ranges", [1.0])
    with pytest.raises(InvalidInput) as caught:
        _scan(ranges, **kwargs)
    assert caught.value.field == field


def test_a_pose_outside_the_map_is_refused() -> None:
    frame = MapFrame((10, 10), 0.1)
    with pytest.raises(InvalidInput) as caught:
        trace_scan(frame, np.zeros((10, 10), bool), _scan([1.0]), (5.0, 0.5, 0.0))
    assert caught.value.field == "scan_pose"

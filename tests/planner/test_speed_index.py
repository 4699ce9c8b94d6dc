"""Speed caps through the zones' speed index: the polygon loop's caps exactly (``naive``), on
random poses, on the zones' edges and vertices and around them, and without a test of every
polygon per point."""

from __future__ import annotations

import math

import numpy as np
import pytest

import planner
from planner.maps import polygons
from tests import naive
from tests.planner.test_zones import star


def random_zones(seed: int, count: int) -> planner.Zones:
    """``count`` overlapping star-shaped speed zones of sizes from a few cm to the whole area
    (20 x 10 m), some tilted far from the origin."""
    rng = np.random.default_rng(seed)
    zones: list[planner.SpeedZone] = []
    while len(zones) < count:
        size = float(np.exp(rng.uniform(math.log(0.03), math.log(12.0))))
        cx, cy = rng.uniform(0, 20), rng.uniform(0, 10)
        points = star(rng, int(rng.integers(3, 40)), cx, cy, size)
        try:  # a star's points at nearly one angle may make it not simple
            polygon = polygons.check_polygon(points, field="speed")
        except planner.InvalidInput:
            continue
        zones.append(planner.SpeedZone(polygon, float(rng.uniform(0.05, 2.0))))
    return planner.Zones(base_map_id="x", speed=tuple(zones))


def probes(zones: planner.Zones, seed: int) -> np.ndarray:
    """Random points over the area and beyond, every vertex, points on the edges, and points a
    hair off them either way."""
    rng = np.random.default_rng(seed)
    out = [rng.uniform(-5, 25, (4000, 2))]
    for zone in zones.speed:
        a = np.asarray(zone.polygon)
        b = np.roll(a, -1, axis=0)
        t = rng.uniform(0, 1, (len(a), 1))
        on = a + t * (b - a)
        normal = (b - a)[:, ::-1] * np.array([1.0, -1.0])
        hair = 1e-9 * normal / np.linalg.norm(normal, axis=1, keepdims=True)
        out += [a, on, on + hair, on - hair]
    return np.concatenate(out)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("count", [1, 5, 60])
def test_speed_caps_are_the_polygon_loops(seed: int, count: int) -> None:
    zones = random_zones(seed, count)
    points = probes(zones, seed)
    got = planner.speed_limits(zones, points)
    want = naive.speed_limits(zones, points)
    assert np.array_equal(got, want), np.flatnonzero(got != want)[:10]
    assert np.isfinite(want).sum() > 0


def test_speed_caps_far_from_the_origin_and_on_a_rotated_map() -> None:
    rng = np.random.default_rng(3)
    speed = tuple(
        planner.SpeedZone(
            polygons.check_polygon(star(rng, 12, 1e6 + x, -3e5, 4.0), field="speed"), 0.5 + x
        )
        for x in (0.0, 3.0, 6.0)
    )
    zones = planner.Zones(base_map_id="x", speed=speed)
    points = np.array([1e6, -3e5]) + rng.uniform(-8, 14, (5000, 2))
    assert np.array_equal(planner.speed_limits(zones, points), naive.speed_limits(zones, points))


def test_a_step_tests_only_the_zones_at_its_poses(monkeypatch: pytest.MonkeyPatch) -> None:
    """256 speed zones in a row: the caps of a step's poses test the few zones whose
    edges pass near them, not the 256 (the loop tested every zone at every step)."""
    squares = tuple(
        planner.SpeedZone(((i, 0.0), (i + 0.9, 0.0), (i + 0.9, 0.9), (i, 0.9)), 0.1 + i / 512)
        for i in range(256)
    )
    zones = planner.Zones(base_map_id="x", speed=squares)
    poses = np.stack([np.linspace(100.2, 100.7, 40), np.full(40, 0.45)], axis=1)
    calls = []
    inside = polygons._inside

    def counting(*args: np.ndarray) -> np.ndarray:
        calls.append(1)
        return inside(*args)

    monkeypatch.setattr(polygons, "_inside", counting)
    caps = planner.speed_limits(zones, poses)
    assert np.allclose(caps, 0.1 + 100 / 512)
    assert len(calls) <= 8, len(calls)


def test_the_index_is_built_once_and_left_out_of_equality() -> None:
    zones = random_zones(0, 5)
    index = zones.speed_index()
    assert zones.speed_index() is index
    again = planner.Zones.from_dict(zones.as_dict())
    assert again == zones
    assert hash(again) == hash(zones)
    assert index.nbytes > 0
    no_speed = planner.Zones(base_map_id="x").speed_index()
    assert no_speed.caps([[0.0, 0.0]]).tolist() == [math.inf]

"""Reeds-Shepp and Dubins curves: exact ends, lengths that match their samples, symmetric
Reeds-Shepp lengths, the turning radius kept, and OMPL's own lengths where it is installed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.motion import dubins, reeds_shepp
from tests import naive_shapes

RADIUS = 0.7


def _pairs(seed: int, n: int) -> list[tuple[tuple[float, ...], tuple[float, ...]]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        a = (rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-4, 4))
        b = (rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-4, 4))
        out.append((tuple(map(float, a)), tuple(map(float, b))))
    return out


@pytest.mark.parametrize("curve", [reeds_shepp, dubins])
def test_curves_end_exactly_and_keep_the_radius(curve: object) -> None:
    for start, goal in _pairs(1, 300):
        c = curve(start, goal, RADIUS)  # type: ignore[operator]
        poses, direction = c.sample(0.01)
        assert np.allclose(poses[0], start)
        assert math.dist(poses[-1][:2], goal[:2]) < 1e-9
        assert abs(math.remainder(poses[-1][2] - goal[2], 2 * math.pi)) < 1e-9
        steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
        assert steps.max() <= 0.01 + 1e-9
        assert steps.sum() == pytest.approx(c.length, abs=1e-3)
        assert naive_shapes.curvatures(poses).max() <= 1 / RADIUS + 1e-6
        assert set(direction.tolist()) <= {1, -1}
        if curve is dubins:
            assert (direction == 1).all()


def test_reeds_shepp_is_symmetric_and_never_longer_than_dubins() -> None:
    for start, goal in _pairs(2, 300):
        rs = reeds_shepp(start, goal, RADIUS).length
        assert rs == pytest.approx(reeds_shepp(goal, start, RADIUS).length, abs=1e-9)
        assert rs <= dubins(start, goal, RADIUS).length + 1e-9
        assert rs >= math.dist(start[:2], goal[:2]) - 1e-9


def test_known_lengths() -> None:
    assert dubins((0, 0, 0), (5, 0, 0), 1.0).length == pytest.approx(5.0)
    assert reeds_shepp((0, 0, 0), (-5, 0, 0), 1.0).length == pytest.approx(5.0)
    # A half turn to the left: pi radii forward.
    assert dubins((0, 0, 0), (0, 2, math.pi), 1.0).length == pytest.approx(math.pi)
    with pytest.raises(ValueError, match="min_turning_radius"):
        reeds_shepp((0, 0, 0), (1, 0, 0), 0.0)


def test_lengths_are_ompls() -> None:
    ob = pytest.importorskip("ompl.base")
    rs_space, du_space = ob.ReedsSheppStateSpace(RADIUS), ob.DubinsStateSpace(RADIUS)
    a, b = rs_space.allocState(), rs_space.allocState()
    for start, goal in _pairs(3, 300):
        a.setX(start[0]), a.setY(start[1]), a.setYaw(start[2])
        b.setX(goal[0]), b.setY(goal[1]), b.setYaw(goal[2])
        assert reeds_shepp(start, goal, RADIUS).length == pytest.approx(rs_space.distance(a, b))
        assert dubins(start, goal, RADIUS).length == pytest.approx(du_space.distance(a, b))

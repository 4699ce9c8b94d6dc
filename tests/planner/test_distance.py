"""The exact distance transform against brute force and against scipy's, squared distances
compared exactly (they are whole numbers of cells squared)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import ndimage

import planner
from planner import InvalidInput
from planner.analysis.distance import squared_distances
from tests import naive


def _scipy(free: np.ndarray, *, outside_blocked: bool) -> np.ndarray:
    """scipy's exact transform, squared and rounded; a blocked ring padded round the array
    when the outside is blocked, and infinite everywhere when nothing is blocked."""
    if not outside_blocked and free.all():
        return np.full(free.shape, np.inf)
    padded = np.pad(free, 1, constant_values=False) if outside_blocked else free
    distance: np.ndarray = ndimage.distance_transform_edt(padded)
    squared: np.ndarray = np.rint(distance**2)
    return squared[1:-1, 1:-1] if outside_blocked else squared


@given(
    st.integers(0, 2**32 - 1),
    st.integers(1, 12),
    st.integers(1, 12),
    st.floats(0.0, 1.0),
    st.booleans(),
)
def test_squared_distances_against_brute_force(
    seed: int, H: int, W: int, share: float, outside_blocked: bool
) -> None:
    free = np.random.default_rng(seed).random((H, W)) >= share
    got = squared_distances(free, outside_blocked=outside_blocked)
    expected = naive.distances(~free, outside_blocked=outside_blocked) ** 2
    np.testing.assert_array_equal(got, np.rint(expected))


@pytest.mark.parametrize("outside_blocked", [False, True])
@pytest.mark.parametrize(
    ("shape", "share"), [((300, 200), 0.001), ((257, 511), 0.05), ((64, 64), 0.5), ((1, 400), 0.01)]
)
def test_squared_distances_match_scipy(
    shape: tuple[int, int], share: float, outside_blocked: bool
) -> None:
    free = np.random.default_rng(7).random(shape) >= share
    got = squared_distances(free, outside_blocked=outside_blocked)
    np.testing.assert_array_equal(got, _scipy(free, outside_blocked=outside_blocked))


@pytest.mark.parametrize("name", ["depot", "smoothers_world"])
def test_squared_distances_on_a_ros_map(ros: Path, name: str) -> None:
    free = planner.read_ros_map(ros / f"{name}.yaml").occupancy < 65
    for outside_blocked in (False, True):
        got = squared_distances(free, outside_blocked=outside_blocked)
        np.testing.assert_array_equal(got, _scipy(free, outside_blocked=outside_blocked))


def test_squared_distances_refuse_what_is_not_a_2d_boolean_grid() -> None:
    with pytest.raises(InvalidInput, match=r"2-D array of booleans.*1-D array of bool"):
        squared_distances(np.ones(3, dtype=bool), outside_blocked=True)
    with pytest.raises(InvalidInput, match=r"2-D array of booleans.*int64"):
        squared_distances(np.ones((2, 2), dtype=np.int64), outside_blocked=True)

"""The row-by-row kernels (the analysis's ``classify`` and ``clean``, the wave's move masks, the
map text's decoding) against the naive references, bit for bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from planner.analysis import cells, clean
from planner.maps import grids
from planner.plans import whole_wave
from tests import naive


@st.composite
def grids_(draw: st.DrawFn) -> np.ndarray:
    h = draw(st.integers(1, 40))
    w = draw(st.integers(1, 40))
    density = draw(st.sampled_from([0.0, 0.2, 0.5, 0.8, 1.0]))
    seed = draw(st.integers(0, 2**32 - 1))
    return (np.random.default_rng(seed).random((h, w)) < density).astype(np.uint8)


@given(grids_())
def test_classify(grid: np.ndarray) -> None:
    state, gates, tunnels = cells.classify(grid)
    ref_state, ref_gates, ref_tunnels = naive.classify(grid)
    np.testing.assert_array_equal(state, ref_state)
    assert (gates, tunnels) == (ref_gates, ref_tunnels)


@given(grids_(), st.booleans(), st.sampled_from([0.5, 1.0, 3.7]), st.integers(1, 8))
def test_clean(grid: np.ndarray, seal: bool, weight: float, radius: int) -> None:
    state = naive.classify(grid)[0]
    got = clean.clean_field(state, seal=seal, weight=weight, radius=radius)
    np.testing.assert_array_equal(got, naive.clean(state, seal, weight, radius))


@given(grids_())
def test_move_masks(grid: np.ndarray) -> None:
    passable = (1 - grid).astype(np.uint8)
    np.testing.assert_array_equal(whole_wave._move_masks(passable), naive.move_masks(passable))


@given(st.binary(max_size=300))
def test_decode_cells(data: bytes) -> None:
    lookup = np.full(256, 255, dtype=np.uint8)
    lookup[ord(".")] = 0
    lookup[ord("@")] = 1
    got, bad = grids._decode_cells(np.frombuffer(data, dtype=np.uint8), lookup)
    want = [int(lookup[b]) for b in data]
    assert got.tolist() == want
    assert bad == next((i for i, v in enumerate(want) if v == 255), -1)

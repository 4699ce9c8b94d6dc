"""The one-pass kernels (``_classify_rows``, ``_clean_rows``, ``_move_masks_rows``,
``_decode_cells``) against the naive references and, bit for bit, against the kernels or numpy
operations they replace."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from planner.analysis import _kernels as K
from tests import naive


@st.composite
def grids(draw: st.DrawFn) -> np.ndarray:
    h = draw(st.integers(1, 40))
    w = draw(st.integers(1, 40))
    density = draw(st.sampled_from([0.0, 0.2, 0.5, 0.8, 1.0]))
    seed = draw(st.integers(0, 2**32 - 1))
    return (np.random.default_rng(seed).random((h, w)) < density).astype(np.uint8)


@given(grids())
def test_classify_rows(grid: np.ndarray) -> None:
    state, gates, tunnels = K._classify_rows(grid)
    ref_state, ref_gates, ref_tunnels = naive.classify(grid)
    np.testing.assert_array_equal(state, ref_state)
    assert (gates, tunnels) == (ref_gates, ref_tunnels)


@given(grids(), st.booleans(), st.sampled_from([0.5, 1.0, 3.7]), st.integers(1, 8))
def test_clean_rows(grid: np.ndarray, seal: bool, weight: float, radius: int) -> None:
    state = naive.classify(grid)[0]
    clean = K._clean_rows(state, seal, weight, radius)
    np.testing.assert_allclose(clean, naive.clean(state, seal, weight, radius), rtol=1e-6)
    np.testing.assert_array_equal(clean, K._clean(state, seal, weight, radius))


@given(grids())
def test_move_masks_rows(grid: np.ndarray) -> None:
    passable = (1 - grid).astype(np.uint8)
    masks = K._move_masks_rows(passable)
    H, W = grid.shape
    for r in range(H):
        for c in range(W):
            want = 0
            if passable[r, c]:
                for i, (dr, dc) in enumerate(naive.MOVES):
                    want |= naive.legal(passable, r, c, dr, dc) << i
            assert masks[r, c] == want, (r, c)
    np.testing.assert_array_equal(masks, K._move_masks(passable))


@given(st.binary(max_size=300))
def test_decode_cells(data: bytes) -> None:
    lookup = np.full(256, 255, dtype=np.uint8)
    lookup[ord(".")] = 0
    lookup[ord("@")] = 1
    cells, bad = K._decode_cells(np.frombuffer(data, dtype=np.uint8), lookup)
    want = [int(lookup[b]) for b in data]
    assert cells.tolist() == want
    assert bad == next((i for i, v in enumerate(want) if v == 255), -1)

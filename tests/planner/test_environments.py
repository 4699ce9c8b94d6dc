"""The six generated environments: reproducible, and Table 1's pairs free and connected."""

from __future__ import annotations

import numpy as np
import pytest

import planner
from planner.experiment.environments import SIZE, TABLE1, connected, environment

SEEDS = (0, 1, 7, 123)


@pytest.mark.parametrize("number", sorted(TABLE1))
def test_reproducible_by_seed(number: int) -> None:
    a = environment(number, seed=5)
    assert a.shape == (SIZE, SIZE)
    assert a.dtype == np.uint8
    assert set(np.unique(a).tolist()) == {0, 1}
    np.testing.assert_array_equal(a, environment(number, seed=5))
    assert not np.array_equal(a, environment(number, seed=6))


@pytest.mark.parametrize("number", sorted(TABLE1))
@pytest.mark.parametrize("seed", SEEDS)
def test_table1_pairs_free_and_connected(number: int, seed: int) -> None:
    grid = environment(number, seed=seed)
    assert len(TABLE1[number]) == 5
    for start, goal in TABLE1[number]:
        assert grid[start] == 0
        assert grid[goal] == 0
        # The planner itself is the independent check of "connected without corner cutting".
        p = planner.plan(grid, start, goal, preset="shortest")
        assert p.path[0].tolist() == list(start)
        assert p.path[-1].tolist() == list(goal)


def test_environments_have_the_papers_character() -> None:
    # Averaged over seeds: env 1 is full of tight tunnels, env 6 has few and no gates, env 4 a
    # gate above each block.
    def mean(number: int, what: str) -> float:
        return float(
            np.mean([getattr(planner.analyse(environment(number, seed=s)), what) for s in SEEDS])
        )

    tunnels = {n: mean(n, "tunnels") for n in TABLE1}
    assert tunnels[1] == max(tunnels.values())
    assert tunnels[6] == min(tunnels.values())
    assert mean(6, "gates") == 0
    assert mean(4, "gates") >= 6
    # Env 1's band across the middle is blocked but for its openings.
    assert environment(1, seed=0)[24:26].mean() > 0.7


def test_connected_is_four_connectivity() -> None:
    grid = np.array([[0, 1, 0], [1, 0, 0], [0, 0, 0]], dtype=np.uint8)
    assert not connected(grid, (((0, 0), (2, 2)),))
    assert connected(grid, (((0, 2), (2, 0)),))
    assert not connected(grid, (((0, 1), (0, 2)),))  # an obstacle is not connected


@pytest.mark.parametrize("bad", [0, 7, True, "1"])
def test_rejects_unknown_environment(bad: object) -> None:
    with pytest.raises(planner.InvalidInput, match="environment number"):
        environment(bad)  # type: ignore[arg-type]


def test_rejects_bad_seed() -> None:
    with pytest.raises(planner.InvalidInput, match="seed must be"):
        environment(1, seed=-1)

"""The experiment's rows, JSON shape and summary comparisons."""

from __future__ import annotations

import json

import pytest

import planner
from planner.cli import main
from planner.experiment import METRICS, PRESET_ORDER, compare, run_experiment


def test_json_has_one_row_per_environment_pair_and_preset(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["experiment", "--episodes", "1", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert isinstance(rows, list)
    assert len(rows) == 6 * 5 * 4
    keys = {(r["environment"], tuple(r["start"]), tuple(r["goal"]), r["preset"]) for r in rows}
    assert len(keys) == len(rows)
    assert {r["preset"] for r in rows} == set(PRESET_ORDER)
    assert {r["environment"] for r in rows} == {1, 2, 3, 4, 5, 6}
    for r in rows:
        assert {"environment", "preset", "start", "goal", *METRICS} <= set(r)
        assert r["collisions"] == 0
        assert r["success"] == 1.0
        assert r["episodes"] == 1
    env1 = [r for r in rows if r["environment"] == 1 and r["preset"] == "wfs-mmas"]
    assert [r["start"] for r in env1] == [[37, 8], [45, 6], [0, 42], [3, 2], [21, 14]]


def test_rows_match_a_hand_run_episode() -> None:
    rows = run_experiment(episodes=2, seed=3, environments=[4], pairs=1, presets=["mmas"])
    (row,) = rows
    grid = planner.environments.environment(4, seed=3)
    p = planner.plan(grid, (3, 6), (47, 14), preset="mmas")
    assert row["gates"] == p.gates
    assert row["tunnels"] == p.tunnels
    assert row["episodes"] == 2
    assert row["iterations"] >= len(p.path) - 1
    assert row["path_length"] >= p.length - 1e-6


def test_summary_printed_with_the_papers_figures(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["experiment", "--episodes", "1"]) == 0
    out = capsys.readouterr().out
    assert "wfs-mmas vs mmas: path cost" in out
    assert "wide vs shortest: path cost" in out
    assert "+11.35%" in out


def test_wide_gains_clearance_over_shortest() -> None:
    rows = run_experiment(episodes=1, environments=[1, 4], presets=["wide", "shortest"])
    gained = compare(rows, "wide", "shortest")
    assert gained["mean_clearance"] > 0
    assert gained["path_length"] >= 0


def test_compare_needs_both_presets() -> None:
    rows = run_experiment(episodes=1, environments=[6], pairs=1, presets=["wide"])
    with pytest.raises(planner.InvalidInput, match="both"):
        compare(rows, "wide", "shortest")


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"episodes": 0}, "episodes"), ({"pairs": 6}, "pairs"), ({"presets": ["fast"]}, "preset")],
)
def test_rejects_bad_arguments(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(planner.InvalidInput, match=match):
        run_experiment(**kwargs)  # type: ignore[arg-type]

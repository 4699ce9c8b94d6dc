"""The experiment's rows, JSON shape and summary comparisons."""

from __future__ import annotations

import json

import numpy as np
import pytest

import planner
from planner.cli import main
from planner.experiment.runs import (
    METRICS,
    PAPER_WEIGHTS,
    PRESET_ORDER,
    compare,
    run_experiment,
    spread,
    summarise,
)


def test_json_has_one_row_per_environment_pair_and_preset(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["experiment", "--episodes", "1", "--seeds", "0", "1", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert isinstance(rows, list)
    assert len(rows) == 2 * 6 * 5 * 4
    keys = {
        (r["seed"], r["environment"], tuple(r["start"]), tuple(r["goal"]), r["preset"])
        for r in rows
    }
    assert len(keys) == len(rows)
    assert {r["preset"] for r in rows} == set(PRESET_ORDER)
    assert {r["environment"] for r in rows} == {1, 2, 3, 4, 5, 6}
    for r in rows:
        assert {"environment", "preset", "start", "goal", *METRICS} <= set(r)
        assert r["collisions"] == 0
        assert r["success"] == 1.0
        assert r["episodes"] == 1
    assert {r["seed"] for r in rows} == {0, 1}
    env1 = [
        r for r in rows if r["environment"] == 1 and r["preset"] == "wfs-mmas" and r["seed"] == 0
    ]
    assert [r["start"] for r in env1] == [[37, 8], [45, 6], [0, 42], [3, 2], [21, 14]]


def test_rows_match_a_hand_run_episode() -> None:
    rows = run_experiment(episodes=2, seeds=[3], environments=[1], pairs=1, presets=["mmas"])
    (row,) = rows
    grid = planner.environment(1, seed=3)
    p = planner.plan(grid, (37, 8), (5, 38), preset="mmas", alpha=5)
    assert (row["seed"], row["alpha"], row["beta"]) == (3, 5.0, 1.0)
    assert row["gates"] == p.gates
    assert row["tunnels"] == p.tunnels
    assert row["episodes"] == 2
    assert row["iterations"] >= len(p.path) - 1
    assert row["path_length"] >= round(p.length, 2) - 1e-6  # rows round to 2 decimals


def test_paper_presets_use_the_papers_weights_per_environment() -> None:
    rows = run_experiment(episodes=1, seeds=[0], pairs=1, presets=["wfs-mmas", "wide"])
    for r in rows:
        if r["preset"] == "wfs-mmas":
            assert (r["alpha"], r["beta"]) == PAPER_WEIGHTS.get(r["environment"], (3.0, 1.0))
        else:
            assert (r["alpha"], r["beta"]) == (3.0, 1.0)  # unused by the wide decision
    assert PAPER_WEIGHTS == {1: (5.0, 1.0), 2: (3.0, 0.0)}


def test_summary_is_each_figure_per_seed_then_its_spread() -> None:
    seeds = [0, 1, 2]
    rows = run_experiment(episodes=1, seeds=seeds, environments=[1, 6], pairs=2)
    s = summarise(rows)
    assert s["seeds"] == seeds
    for (preset, baseline), figures in s["comparisons"].items():
        per_seed = [compare([r for r in rows if r["seed"] == x], preset, baseline) for x in seeds]
        for key, fig in figures.items():
            values = [c[key] for c in per_seed]
            assert list(fig.values) == pytest.approx(values, abs=0.01)
            assert fig.median == pytest.approx(float(np.median(values)), abs=0.01)
            assert fig.low == pytest.approx(min(values), abs=0.01)
            assert fig.high == pytest.approx(max(values), abs=0.01)
    one = s["environments"][6]["arc_cost"]
    env6 = [
        compare([r for r in rows if r["seed"] == x and r["environment"] == 6], "wfs-mmas", "mmas")
        for x in seeds
    ]
    assert list(one.values) == pytest.approx([c["arc_cost"] for c in env6], abs=0.01)
    tunnels = {(r["seed"], r["environment"]): r["tunnels"] for r in rows}
    for n in (1, 6):
        most = sum(tunnels[(x, n)] >= tunnels[(x, 7 - n)] for x in seeds)
        assert s["rank"]["most_tunnels"][n] == most


def test_spread_quartiles() -> None:
    s = spread([4.0, 1.0, 3.0, 2.0])
    assert (s.median, s.q1, s.q3, s.low, s.high) == (2.5, 1.75, 3.25, 1.0, 4.0)
    assert s.count(lambda v: v > 2) == 2
    assert str(s) == "+2.5% [IQR +1.8 .. +3.2; range +1.0 .. +4.0]"


def test_cli_prints_the_measured_figures_and_claim_counts(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["experiment", "--episodes", "1", "--seeds", "0", "1"]) == 0
    out = capsys.readouterr().out
    s = summarise(run_experiment(episodes=1, seeds=[0, 1]))
    cost = s["comparisons"][("wfs-mmas", "mmas")]["arc_cost"]
    assert f"path cost       {cost}" in out
    wide = s["comparisons"][("wide", "shortest")]["mean_clearance"]
    assert f"mean clearance  {wide}" in out
    higher = cost.count(lambda v: v > 0)
    assert f"{'path cost higher (the paper: +11.35%)':<40} {higher}/2 seeds" in out
    most = s["rank"]["most_tunnels"][1]
    assert f"{'environment 1 has the most tunnels':<40} {most}/2 seeds" in out
    assert "D* + PSO, is not implemented" in out


def test_wide_gains_clearance_over_shortest() -> None:
    rows = run_experiment(
        episodes=1, seeds=[0, 1], environments=[1, 4], presets=["wide", "shortest"]
    )
    gained = compare(rows, "wide", "shortest")
    assert gained["mean_clearance"] > 0
    assert gained["path_length"] >= 0


def test_compare_needs_both_presets() -> None:
    rows = run_experiment(episodes=1, seeds=[0], environments=[6], pairs=1, presets=["wide"])
    with pytest.raises(planner.InvalidInput, match="both"):
        compare(rows, "wide", "shortest")


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"episodes": 0}, "episodes"),
        ({"pairs": 6}, "pairs"),
        ({"presets": ["fast"]}, "preset"),
        ({"seeds": []}, "seeds"),
    ],
)
def test_rejects_bad_arguments(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(planner.InvalidInput, match=match):
        run_experiment(**kwargs)  # type: ignore[arg-type]

"""External truth: preset ``shortest`` reproduces the Moving AI optimal lengths (tolerance 1e-3):
every line for maps of 256 x 256 cells or fewer, 80 lines spread over each larger map's file
(``make scen-all`` checks every line of every file)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import planner
from tests.conftest import MOVINGAI

TOLERANCE = 1e-3
SAMPLE = 80
SCENARIOS = sorted(p.name for p in MOVINGAI.glob("*.scen")) if MOVINGAI.is_dir() else []


def test_the_benchmark_set_is_there(movingai: Path) -> None:
    assert len(SCENARIOS) >= 13


@pytest.mark.parametrize("name", SCENARIOS)
def test_shortest_matches_the_optimal_lengths(movingai: Path, name: str) -> None:
    lines = planner.read_scen(movingai / name)
    grid = planner.read_map(movingai / Path(lines[0].map_name).name)
    assert grid.shape == (lines[0].height, lines[0].width)
    if grid.size > 256 * 256:
        picks = np.linspace(0, len(lines) - 1, SAMPLE).round().astype(int)
        lines = [lines[i] for i in picks]
    analysis = planner.analyse(grid, seal_tunnels=False, clean_weight=0.0, clean_radius=1)
    errors = []
    for line in lines:
        p = planner.plan(None, line.start, line.goal, preset="shortest", analysis=analysis)
        errors.append(abs(p.length - line.optimal))
        # The path is a legal chain of moves, and its length is the wave's cost-to-go.
        assert abs(p.length - p.wave.k[line.start]) < 1e-9
    worst = int(np.argmax(errors))
    assert errors[worst] <= TOLERANCE, f"{name}: {lines[worst]} off by {errors[worst]}"
    assert len(errors) >= min(SAMPLE, len(planner.read_scen(movingai / name)))


def test_scen_cli_reports_zero_mismatches(
    movingai: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from planner.cli import main

    code = main(["scen", str(movingai / "arena.map.scen")])
    out = capsys.readouterr().out
    assert code == 0
    assert '"mismatches": 0' in out
    assert '"lines": 160' in out

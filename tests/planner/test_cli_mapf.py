"""``python -m planner mapf``: a Moving AI MAPF instance solved from the command line, as text
and as JSON whose paths the independent validator accepts."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import planner
from planner.cli import main
from planner.fleets import grid_graph
from tests import naive_mapf


@pytest.fixture
def instance(tmp_path: Path) -> tuple[Path, Path]:
    """A 4x5 room with a pillar, and a scenario of four agents crossing it."""
    room = tmp_path / "room.map"
    room.write_text("type octile\nheight 4\nwidth 5\nmap\n.....\n.@...\n.....\n.....\n")
    scen = tmp_path / "room.scen"
    lines = [(0, 0, 4, 3), (4, 3, 0, 0), (0, 3, 4, 0), (4, 0, 0, 3)]  # x, y (col, row)
    scen.write_text(
        "version 1\n"
        + "".join(f"0\troom.map\t5\t4\t{a}\t{b}\t{c}\t{d}\t7\n" for a, b, c, d in lines)
    )
    return room, scen


def test_mapf_prints_a_summary_line(
    instance: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    room, scen = instance
    assert main(["mapf", str(room), str(scen), "--agents", "4"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("solved: 4 agents on room.map, sum of costs ")
    assert "lower bound 28, ratio " in out


def test_mapf_json_paths_are_a_valid_solution(
    instance: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    room, scen = instance
    code = main(["mapf", str(room), str(scen), "--agents", "3", "--seed", "2", "--json", "--paths"])
    assert code == 0
    answer = json.loads(capsys.readouterr().out)
    assert answer["status"] == "solved"
    assert answer["agents"] == len(answer["paths"]) == 3
    assert answer["ratio"] == round(answer["sum_of_costs"] / answer["lower_bound"], 4)
    graph = grid_graph(planner.read_map(room) == 0)
    paths = np.stack([graph.node_of(cells) for cells in answer["paths"]], axis=1)
    starts, goals = paths[0].tolist(), paths[-1].tolist()
    assert graph.cells[starts].tolist() == [[0, 0], [3, 4], [3, 0]]
    soc, makespan = naive_mapf.check_solution(graph, starts, goals, paths)
    assert (soc, makespan) == (answer["sum_of_costs"], answer["makespan"])


def test_mapf_refuses_more_agents_than_the_scenario_has(
    instance: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    room, scen = instance
    assert main(["mapf", str(room), str(scen), "--agents", "5"]) == 2
    assert "--agents: 1..4 (the lines of room.scen), 5 given" in capsys.readouterr().err


def test_mapf_names_an_agent_on_a_wall(
    instance: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    room, scen = instance
    scen.write_text(scen.read_text().replace("0\troom.map\t5\t4\t0\t0", "0\troom.map\t5\t4\t1\t1"))
    assert main(["mapf", str(room), str(scen), "--agents", "2"]) == 2
    assert "start [1, 1] of agent 0 is not a free cell" in capsys.readouterr().err

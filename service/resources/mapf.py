"""Offline MAPF over HTTP (docs/fleets.md, "The solver"): agents planned together on a map's
roadmap for their radius, by the same solver as a fleet's joint plan."""

from __future__ import annotations

from typing import Any

import numpy as np

import planner
from planner.fleets import Graph, Solution, attach, solve
from planner.plans.ends import free_cell
from schemas import MapfCreate
from service.resources import fleets
from service.resources.mapf_size import check_size
from service.work.engine import Engine

__all__ = ["paths_of", "solve_mapf"]


async def solve_mapf(engine: Engine, map_id: str, body: MapfCreate) -> tuple[Solution, Graph]:
    """The agents' joint plan on the map's roadmap for ``robot_radius`` (cached with the
    analysis), within ``time_limit_s`` and the request's own timeout."""
    await engine.require_map(map_id)
    params = planner.resolve_params(body.preset, robot_radius=body.robot_radius)
    record = {"map_id": map_id, "radius": body.robot_radius, "params": params.as_dict()}
    fmap = await fleets.fleet_map(engine, record)
    graph, analysis = fmap.graph, fmap.analysis
    check_size(len(body.agents), graph, "agents")
    starts = _nodes(graph, analysis, [a.start for a in body.agents], "start")
    goals = _nodes(graph, analysis, [a.goal for a in body.agents], "goal")
    budget = min(body.time_limit_s, 0.8 * engine.settings.request_timeout_seconds)
    solution = await engine.pool.run(solve, graph, starts, goals, time_limit_s=budget)
    return solution, graph


def _nodes(graph: Graph, analysis: planner.Analysis, cells: list[Any], end: str) -> list[int]:
    """Each cell's node: its own, or the nearest it joins by a straight move that no earlier
    agent's joins; ``InvalidInput`` naming ``agents[i].start`` (or ``goal``) otherwise."""
    taken: set[int] = set()
    out = []
    for i, cell in enumerate(cells):
        name = f"agents[{i}].{end}"
        r, c = free_cell(analysis, cell, name)
        node = int(graph.node_of([(r, c)])[0])
        if node < 0 or node in taken:
            node = attach(graph, analysis, (r, c), exclude=taken)
        if node < 0:
            msg = f"{name} [{r}, {c}] joins no free node of the roadmap by a straight move"
            raise planner.InvalidInput(msg, field=name)
        taken.add(node)
        out.append(node)
    return out


def paths_of(solution: Solution, graph: Graph) -> list[list[list[int]]]:
    """Each agent's cells over time (an empty list each when not solved)."""
    if not solution.solved:
        return [[] for _ in range(solution.paths.shape[1])]
    cells = graph.cells[solution.paths]  # (T + 1, k, 2)
    return np.transpose(cells, (1, 0, 2)).tolist()  # type: ignore[no-any-return]

"""``python -m planner mapf``: a Moving AI MAPF instance (a ``.map`` and the first N agents of a
``.scen``) solved by LaCAM with PIBT, as a line of text or a JSON object."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from planner.errors import InvalidInput
from planner.fleets.graph import grid_graph
from planner.fleets.mapf import Solution, solve
from planner.maps.grids import read_map, read_scen

__all__ = ["add_mapf_command", "warm_up_mapf"]


def add_mapf_command(sub: Any) -> None:
    """Add the ``mapf`` command to the command line's subparsers."""
    p = sub.add_parser("mapf", help="solve a Moving AI MAPF instance: a .map, a .scen's first N")
    p.add_argument("map", type=Path, help="the Moving AI .map file")
    p.add_argument("scen", type=Path, help="the .scen file: its first N lines are the agents")
    p.add_argument("--agents", type=int, required=True, metavar="N", help="how many agents")
    p.add_argument("--time-limit", type=float, default=10.0, metavar="S", help="seconds (10)")
    p.add_argument("--seed", type=int, default=0, help="PIBT's tie-breaks and the search order")
    p.add_argument(
        "--refine", action="store_true",
        help="keep improving the sum of costs until the time limit (LaCAM*)",
    )  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--paths", action="store_true", help="with --json: each agent's [row, col]s")
    p.set_defaults(run=_mapf)


def warm_up_mapf() -> None:
    """Compile (or load from numba's cache) the solver's kernels on a tiny instance, so that
    the times reported are the solver's."""
    solve(grid_graph([[1, 1, 1], [0, 1, 0]]), [0, 2], [2, 0], refine=True)


def _mapf(args: argparse.Namespace) -> int:
    lines = read_scen(args.scen)
    if not 1 <= args.agents <= len(lines):
        msg = f"--agents: 1..{len(lines)} (the lines of {args.scen.name}), {args.agents} given"
        raise InvalidInput(msg, field="agents")
    lines = lines[: args.agents]
    graph = grid_graph(read_map(args.map) == 0)
    starts = graph.node_of([line.start for line in lines])
    goals = graph.node_of([line.goal for line in lines])
    for name, nodes, cells in (
        ("start", starts, [line.start for line in lines]),
        ("goal", goals, [line.goal for line in lines]),
    ):
        if (nodes < 0).any():
            agent = int((nodes < 0).argmax())
            msg = f"{name} {list(cells[agent])} of agent {agent} is not a free cell of the map"
            raise InvalidInput(msg, field=name)
    warm_up_mapf()
    found = solve(
        graph, starts, goals, time_limit_s=args.time_limit, seed=args.seed, refine=args.refine
    )
    summary = _summary(found, args)
    if args.json:
        if args.paths and found.solved:
            summary["paths"] = graph.cells[found.paths.T].tolist()
        print(json.dumps(summary))
    else:
        ratio = "" if summary["ratio"] is None else f", ratio {summary['ratio']:.3f}"
        print(
            f"{found.status}: {args.agents} agents on {args.map.name}, sum of costs "
            f"{found.sum_of_costs} (lower bound {found.lower_bound}{ratio}), makespan "
            f"{found.makespan}, {found.solve_ms:.1f} ms ({found.expanded} constraints tried, "
            f"{found.configurations} configurations)"
        )
    return 0 if found.solved else 1


def _summary(found: Solution, args: argparse.Namespace) -> dict[str, Any]:
    ratio = found.sum_of_costs / found.lower_bound if found.solved and found.lower_bound else None
    return {
        "map": str(args.map),
        "scen": str(args.scen),
        "agents": args.agents,
        "status": found.status,
        "solved": found.solved,
        "sum_of_costs": found.sum_of_costs,
        "lower_bound": found.lower_bound,
        "ratio": None if ratio is None else round(ratio, 4),
        "makespan": found.makespan,
        "solve_ms": round(found.solve_ms, 3),
        "expanded": found.expanded,
        "configurations": found.configurations,
    }

"""MAPF on the Moving AI benchmark (the shared ``maps/mapf``): LaCAM with PIBT on six maps and
their four scenario files, a sweep of agent counts on one core within a time budget; success
rate, median sum of costs over its lower bound, median and max solve time as a markdown table.
Then one PIBT step in numba against a plain-Python PIBT::

    .venv/bin/python benchmarks/mapf.py              # the whole sweep (a few minutes)
    .venv/bin/python benchmarks/mapf.py --largest    # each map at its largest count only
    .venv/bin/python benchmarks/mapf.py --quick      # the largest counts on one scenario each
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from common import ROOT

sys.path.insert(0, str(ROOT))

import planner
from planner.fleets import Graph, grid_graph, solve
from planner.fleets.distances import cost_distances
from planner.fleets.pibt import Pibt

SMALL = (50, 100, 150, 200)
LARGE = (100, 200, 300, 400, 500)
MAPS = {
    "empty-32-32": SMALL,
    "random-32-32-10": SMALL,
    "room-32-32-4": SMALL,
    "maze-32-32-2": SMALL,
    "den312d": LARGE,
    "warehouse-10-20-10-2-1": LARGE,
}
SCENS = ("even-1", "even-2", "random-1", "random-2")


def mapf_maps() -> Path:
    """The shared Moving AI MAPF maps: beside the repository or beside the folder holding it."""
    for base in (ROOT.parent, ROOT.parent.parent):
        candidate = base / "shared" / "maps" / "mapf"
        if candidate.is_dir():
            return candidate
    raise SystemExit(f"the MAPF maps are not in {ROOT.parent}/shared or {ROOT.parent.parent}")


def cpu() -> str:
    text = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    return next(
        (ln.split(":", 1)[1].strip() for ln in text.splitlines() if "Model name" in ln), "?"
    )


def instance(folder: Path, name: str, scen: str, agents: int) -> tuple[Graph, list[int], list[int]]:
    graph = grid_graph(planner.read_map(folder / f"{name}.map") == 0)
    lines = planner.read_scen(folder / f"{name}-{scen}.scen")[:agents]
    starts = graph.node_of([line.start for line in lines]).tolist()
    goals = graph.node_of([line.goal for line in lines]).tolist()
    return graph, starts, goals


def sweep(folder: Path, largest: bool, quick: bool, limit: float) -> None:
    print("| map | agents | solved | SoC / LB (median) | median ms | max ms |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, counts in MAPS.items():
        for count in counts[-1:] if largest or quick else counts:
            solved, ratios, times, agents = 0, [], [], set()
            scens = SCENS[2:3] if quick else SCENS
            for scen in scens:
                graph, starts, goals = instance(folder, name, scen, count)
                agents.add(len(starts))  # a scenario may hold fewer lines than asked
                found = solve(graph, starts, goals, time_limit_s=limit)
                times.append(found.solve_ms)
                if found.solved:
                    solved += 1
                    ratios.append(found.sum_of_costs / found.lower_bound)
            ratio = f"{statistics.median(ratios):.3f}" if ratios else "-"
            print(
                f"| {name} | {'/'.join(map(str, sorted(agents)))} | {solved}/{len(scens)} | "
                f"{ratio} | {statistics.median(times):.0f} | {max(times):.0f} |",
                flush=True,
            )


def python_pibt_step(
    nbrs: list[list[int]], rows: list[list[float]], q_from: list[int], order: list[int]
) -> list[int]:
    """PIBT's step as the papers write it, in plain Python (no swap, no fixed moves), over
    ``nbrs[v]`` (node ``v``'s neighbours) and ``rows[i][v]`` (agent ``i``'s cost to go)."""
    now = {v: i for i, v in enumerate(q_from)}
    q_to: list[int | None] = [None] * len(q_from)
    nxt: dict[int, int] = {}

    def plan(i: int) -> bool:
        v = q_from[i]
        for u in sorted([*nbrs[v], v], key=rows[i].__getitem__):
            j = now.get(u)
            if u in nxt or (j is not None and j != i and q_to[j] == v):
                continue
            nxt[u], q_to[i] = i, u
            if j is not None and j != i and q_to[j] is None and not plan(j):
                continue
            return True
        nxt[v], q_to[i] = i, v
        return False

    for i in order:
        if q_to[i] is None:
            plan(i)
    return [v for v in q_to if v is not None]


def pibt_speed(folder: Path) -> None:
    """Mean time of one PIBT step over the first steps from the starts: numba (``Pibt.step``,
    with the swap check) against plain Python."""
    sys.setrecursionlimit(10_000)
    print("\n| map | agents | numba step µs | Python step µs | speed-up |")
    print("|---|---:|---:|---:|---:|")
    for name, count in (("random-32-32-10", 200), ("warehouse-10-20-10-2-1", 500)):
        graph, starts, goals = instance(folder, name, "random-1", count)
        pref = cost_distances(graph, goals)
        order = np.argsort(-pref[np.arange(count), starts], kind="stable")
        pibt = Pibt(graph, np.array(goals), pref)
        q = np.array(starts, dtype=np.int64)
        pibt.step(q, order)  # compiled or loaded
        t = time.perf_counter()
        for step in range(20):
            q = pibt.step(q, order, salt=step)  # type: ignore[assignment]
        fast = (time.perf_counter() - t) / 20 * 1e6
        config, nbrs, rows = (
            list(starts),
            [graph.neighbours(v).tolist() for v in range(graph.nodes)],
            pref.tolist(),
        )
        t = time.perf_counter()
        for _ in range(20):
            config = python_pibt_step(nbrs, rows, config, order.tolist())
        slow = (time.perf_counter() - t) / 20 * 1e6
        print(f"| {name} | {count} | {fast:.0f} | {slow:.0f} | {slow / fast:.0f}x |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("::")[0])
    parser.add_argument("--quick", action="store_true", help="largest counts, one scenario")
    parser.add_argument("--largest", action="store_true", help="largest counts, four scenarios")
    parser.add_argument("--time-limit", type=float, default=10.0, metavar="S")
    args = parser.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core
    folder = mapf_maps()
    solve(grid_graph([[1, 1, 1], [0, 1, 0]]), [0, 2], [2, 0])  # compile or load the kernels
    print(f"CPU: {cpu()}, one core; {args.time_limit:g} s a solve\n")
    sweep(folder, args.largest, args.quick, args.time_limit)
    pibt_speed(folder)


if __name__ == "__main__":
    main()

"""The fleet roadmap on the shared ROS maps: build time, node and edge counts, coverage (random
pairs of cells a single robot's ``wide`` plan travels between, joined through the roadmap: the
goal at its nearest node, the start at the node that leads there best) and route length (that
route, its straight ends included, against the single-robot ``wide`` plan's path)::

    .venv/bin/python benchmarks/roadmap.py                 # every map, r = 0.15, 0.22, 0.3
    .venv/bin/python benchmarks/roadmap.py --pairs 200 --plans 100
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

from common import ROOT, ros_maps

sys.path.insert(0, str(ROOT))

import numpy as np
from scipy import ndimage

import planner
from planner.fleets.roadmap import attach_all, build_roadmap
from tests import naive_roadmap

MAPS = ("depot", "smoothers_world", "tb3_sandbox", "TenByTen", "testmap")


def reachable_pairs(
    analysis: planner.Analysis, count: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """``count`` pairs of two different cells a single robot's ``wide`` plan travels between:
    cells not blocked (tight tunnels too: the plan falls back to them) in one 4-connected
    region (a diagonal move needs both cells beside it free, so 8-connected moves join
    exactly the cells 4-connected ones do). The start is any cell of a region of two cells
    or more, the goal any other cell of its region."""
    free = analysis.state != 1
    labels, _ = ndimage.label(free)
    sizes = np.bincount(labels.ravel())
    cells = np.argwhere(free & (sizes[labels] >= 2))
    if len(cells) == 0:
        return np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64)
    starts = cells[rng.integers(len(cells), size=count)]
    goals = np.empty_like(starts)
    for k, (r, c) in enumerate(starts.tolist()):
        same = np.argwhere(labels == labels[r, c])
        same = same[(same[:, 0] != r) | (same[:, 1] != c)]
        goals[k] = same[rng.integers(len(same))]
    return starts, goals


def measure(name: str, radius: float, pairs: int, plans: int, seed: int) -> dict[str, float]:
    robot_map = planner.read_ros_map(ros_maps() / f"{name}.yaml")
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=radius))
    build_roadmap(analysis, radius=radius)  # compiled and warm
    t0 = time.perf_counter()
    graph = build_roadmap(analysis, radius=radius)
    build_ms = (time.perf_counter() - t0) * 1e3
    rng = np.random.default_rng(seed)
    starts, goals = reachable_pairs(analysis, pairs, rng)
    g_nodes = attach_all(graph, analysis, goals)
    s_nodes = attach_all(graph, analysis, starts, toward=g_nodes)
    labels = naive_roadmap.components(graph) if graph.nodes else np.zeros(0, np.int64)
    joined = (s_nodes >= 0) & (g_nodes >= 0)
    joined[joined] &= labels[s_nodes[joined]] == labels[g_nodes[joined]]
    out = {
        "nodes": graph.nodes,
        "edges": graph.edges,
        "build_ms": build_ms,
        "pairs": len(starts),
        "covered": float(joined.mean()) if len(starts) else float("nan"),
    }
    ratios = []
    for k in np.flatnonzero(joined)[:plans].tolist():
        s, g = starts[k], goals[k]
        plan = planner.plan(
            robot_map, s.tolist(), g.tolist(), preset="wide", analysis=analysis,
            robot_radius=radius,
        )  # fmt: skip
        route = naive_roadmap.route_lengths(
            graph, starts[k : k + 1], goals[k : k + 1], s_nodes[k : k + 1], g_nodes[k : k + 1]
        )[0]
        ratios.append(route * robot_map.resolution / plan.length_m)
    if ratios:
        out["median"] = statistics.median(ratios)
        out["p90"] = float(np.percentile(ratios, 90))
        out["routes"] = len(ratios)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--maps", nargs="*", default=list(MAPS))
    parser.add_argument("--radii", nargs="*", type=float, default=[0.15, 0.22, 0.3])
    parser.add_argument("--pairs", type=int, default=200, help="random pairs for coverage")
    parser.add_argument("--plans", type=int, default=60, help="of them, planned for length")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print("| map | r (m) | nodes | edges | build (ms) | covered | route/plan median | p90 |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.maps:
        for radius in args.radii:
            m = measure(name, radius, args.pairs, args.plans, args.seed)
            covered = f"{m['covered']:.1%} of {m['pairs']}" if m["pairs"] else "no two cells"
            median, p90 = (f"{m[k]:.3f}" if k in m else "-" for k in ("median", "p90"))
            print(
                f"| {name} | {radius:g} | {m['nodes']} | {m['edges']} | {m['build_ms']:.1f} | "
                f"{covered} | {median} | {p90} |",
                flush=True,
            )


if __name__ == "__main__":
    main()

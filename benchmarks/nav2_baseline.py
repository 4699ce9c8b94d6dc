"""``wide`` against a Nav2-style planner on the same configuration space, on the ROS maps.

The baseline is what a Nav2 user runs: an inflation layer, cost ``252 * exp(-3.0 * (d - r))``
for ``r < d <= 0.55`` m (``d``: distance from a cell's center to the nearest blocked cell's
center, ``r``: the robot's radius), and a plain Dijkstra whose move into a cell costs
``(50 + 0.8 * cost) * step length``, 8-connected, no corner cutting, over the same traversable
cells as ours (``planner.configuration_space``). For seeded start/goal pairs (connected,
far apart) it reports per map the medians and IQRs of ``wide / nav2`` path length and mean
clearance, and times reading + analysis + first plan of every shared map. Run::

    .venv/bin/python benchmarks/nav2_baseline.py            # prints, writes RESULTS.md's section
    .venv/bin/python benchmarks/nav2_baseline.py --no-write
"""

from __future__ import annotations

import argparse
import heapq
import math
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from common import ROOT, ros_maps
from numba import njit

sys.path.insert(0, str(ROOT))

import planner
from planner import CSpace, configuration_space

RESULTS = ROOT / "benchmarks" / "RESULTS.md"
FIGURE = ROOT / "docs" / "figures" / "depot-wide-vs-nav2.png"
MARK = "<!-- nav2-baseline -->"
MAPS = ("depot", "tb3_sandbox", "smoothers_world")
ALL_MAPS = ("depot", "tb3_sandbox", "smoothers_world", "TenByTen", "testmap")
RADIUS = 0.22
INFLATION = 0.55
SCALING = 3.0
DR = np.array([-1, -1, 0, 1, 1, 1, 0, -1], dtype=np.int64)
DC = np.array([0, 1, 1, 1, 0, -1, -1, -1], dtype=np.int64)


def inflation_cost(cs: CSpace) -> npt.NDArray[np.float64]:
    """Nav2's inflation layer on the configuration space (0 beyond ``INFLATION`` meters)."""
    d = cs.distance_m
    cost = np.where(d <= INFLATION, 252.0 * np.exp(-SCALING * (d - cs.robot_radius)), 0.0)
    out: npt.NDArray[np.float64] = np.where(cs.traversable == 1, cost, np.inf)
    return out


@njit(cache=True, nogil=True)
def _dijkstra(cost: np.ndarray, start: int, goal: int) -> np.ndarray:
    """Cells (flat) of the cheapest path, moves into Y costing (50 + 0.8 cost(Y)) * length."""
    H, W = cost.shape
    flat = cost.ravel()
    dist = np.full(H * W, np.inf)
    parent = np.full(H * W, -1, dtype=np.int64)
    done = np.zeros(H * W, dtype=np.uint8)
    dist[start] = 0.0
    heap = [(0.0, start)]
    while heap:
        d, x = heapq.heappop(heap)
        if done[x]:
            continue
        done[x] = 1
        if x == goal:
            break
        r = x // W
        c = x - r * W
        for i in range(8):
            yr = r + DR[i]
            yc = c + DC[i]
            if yr < 0 or yr >= H or yc < 0 or yc >= W:
                continue
            y = yr * W + yc
            if flat[y] == np.inf or done[y]:
                continue
            if i & 1 and (flat[r * W + yc] == np.inf or flat[yr * W + c] == np.inf):
                continue
            nd = d + (50.0 + 0.8 * flat[y]) * (math.sqrt(2.0) if i & 1 else 1.0)
            if nd < dist[y]:
                dist[y] = nd
                parent[y] = x
                heapq.heappush(heap, (nd, y))
    if dist[goal] == np.inf:
        return np.empty(0, dtype=np.int64)
    n = 1
    x = goal
    while x != start:
        x = parent[x]
        n += 1
    out = np.empty(n, dtype=np.int64)
    x = goal
    for j in range(n - 1, -1, -1):
        out[j] = x
        x = parent[x]
    return out


def nav2_path(cost: npt.NDArray[np.float64], start: Any, goal: Any) -> npt.NDArray[np.int64]:
    W = cost.shape[1]
    flat = _dijkstra(cost, int(start[0]) * W + int(start[1]), int(goal[0]) * W + int(goal[1]))
    out: npt.NDArray[np.int64] = np.stack(np.divmod(flat, W), axis=1)
    return out


def length_m(path: npt.NDArray[np.int64], resolution: float) -> float:
    steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
    return float(np.count_nonzero(steps == 1) + np.count_nonzero(steps == 2) * math.sqrt(2)) * (
        resolution
    )


def mean_clearance_m(path: npt.NDArray[np.int64], cs: CSpace) -> float:
    return float(cs.distance_m[path[:, 0], path[:, 1]].mean())


def pairs(cs: CSpace, cost: npt.NDArray[np.float64], count: int, seed: int) -> list[Any]:
    """Seeded start/goal pairs of traversable cells, connected, at least a third of the
    diagonal of the traversable area's bounding box apart; each with its Nav2 path."""
    rng = np.random.default_rng(seed)
    cells = np.argwhere(cs.traversable == 1)
    H, W = cells.max(axis=0) - cells.min(axis=0) + 1
    far = math.hypot(H, W) / 3
    out: list[Any] = []
    tries = 0
    while len(out) < count:
        tries += 1
        if tries > 200 * count:
            raise SystemExit(f"found only {len(out)} connected pairs after {tries} tries")
        s, g = cells[rng.integers(len(cells), size=2)]
        if math.hypot(*(s - g)) < far:
            continue
        path = nav2_path(cost, s, g)
        if path.size:
            out.append((tuple(s.tolist()), tuple(g.tolist()), path))
    return out


@dataclass
class Row:
    name: str
    pairs: int
    length: npt.NDArray[np.float64]
    clearance: npt.NDArray[np.float64]
    narrow: int


def compare(name: str, folder: Path, count: int, seed: int, params: dict[str, Any]) -> Row:
    robot_map = planner.read_ros_map(folder / f"{name}.yaml")
    cs = configuration_space(robot_map, robot_radius=RADIUS)
    cost = inflation_cost(cs)
    p = planner.resolve_params("wide", robot_radius=RADIUS, **params)
    analysis = planner.analyse_map(robot_map, p)
    lengths, clearances, narrow = [], [], 0
    for s, g, base in pairs(cs, cost, count, seed):
        wide = planner.plan(robot_map, s, g, analysis=analysis, robot_radius=RADIUS, **params)
        narrow += wide.narrow_fallback
        lengths.append(wide.length_m / length_m(base, cs.resolution))
        clearances.append(wide.mean_clearance_m / mean_clearance_m(base, cs))
    return Row(name, count, np.array(lengths), np.array(clearances), narrow)


def figure(folder: Path, seed: int) -> None:
    """Both planners' paths between a few seeded pairs on depot, drawn over its C-space."""
    from planner.render import draw
    from planner.render_legend import COLOURS

    robot_map = planner.read_ros_map(folder / "depot.yaml")
    cs = configuration_space(robot_map, robot_radius=RADIUS)
    cost = inflation_cost(cs)
    analysis = planner.analyse_map(robot_map, planner.resolve_params("wide", robot_radius=RADIUS))
    paths: list[Any] = []
    for i, (s, g, base) in enumerate(pairs(cs, cost, 3, seed)):
        wide = planner.plan(robot_map, s, g, analysis=analysis, robot_radius=RADIUS)
        paths += [
            (base, (150, 0, 200), "Nav2-style" if i == 0 else ""),
            (wide.path, COLOURS["path"], "wide" if i == 0 else ""),
        ]
    image = draw(
        analysis, paths=paths, start=paths[1][0][0], goal=paths[1][0][-1], cell=None, legend=True
    )
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    image.save(FIGURE, optimize=True)
    print(f"wrote {FIGURE.relative_to(ROOT)}")


def first_plan_times(folder: Path) -> list[tuple[str, str, float, float, float]]:
    """(map, size, read + parse ms, analysis ms, first plan ms) for every shared map, with the
    default ``wide`` preset and a 0.22 m robot (0 on the two small maps), between two far cells."""
    out = []
    for name in ALL_MAPS:
        yaml_bytes = (folder / f"{name}.yaml").read_bytes()
        meta = planner.parse_map_yaml(yaml_bytes)
        t0 = time.perf_counter()
        image = (folder / meta.image).read_bytes()
        robot_map = planner.parse_ros_map(yaml_bytes, image)
        t1 = time.perf_counter()
        radius = RADIUS if robot_map.resolution <= 0.05 else 0.0
        p = planner.resolve_params("wide", robot_radius=radius)
        analysis = planner.analyse_map(robot_map, p)
        t2 = time.perf_counter()
        cells = np.argwhere(analysis.passable() == 1)
        s, g = cells[0], cells[-1]
        planner.plan(robot_map, s, g, analysis=analysis, robot_radius=radius).summary()
        t3 = time.perf_counter()
        size = f"{robot_map.shape[1]} x {robot_map.shape[0]}"
        out.append((name, size, (t1 - t0) * 1e3, (t2 - t1) * 1e3, (t3 - t2) * 1e3))
    return out


def iqr(values: npt.NDArray[np.float64]) -> str:
    q1, q3 = np.percentile(values, [25, 75])
    return f"{q1:.3f}-{q3:.3f}"


def table(rows: list[Row]) -> list[str]:
    lines = [
        "| map | pairs | length wide / nav2: median | IQR | mean clearance wide / nav2: median "
        "| IQR | narrow fallbacks |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.name} | {r.pairs} | **{np.median(r.length):.3f}** | {iqr(r.length)} "
            f"| **{np.median(r.clearance):.3f}** | {iqr(r.clearance)} | {r.narrow} |"
        )
    return lines


def cpu() -> str:
    try:
        text = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return platform.processor() or "unknown CPU"
    fields = dict(line.split(":", 1) for line in text.splitlines() if ":" in line)
    model = fields.get("Model name", "unknown").strip()
    return f"{model}, {fields.get('CPU(s)', '?').strip()} cores"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=30, help="start/goal pairs per map")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument(
        "--other-seeds", type=int, nargs="*", default=[1, 2], help="seeds checked too, briefly"
    )
    parser.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md")
    args = parser.parse_args()
    params = {k: float(v) for k, v in (a.split("=", 1) for a in args.param)}
    folder = ros_maps()
    planner.warm_up()
    default = planner.resolve_params("wide")
    rows = [compare(name, folder, args.pairs, args.seed, params) for name in MAPS]
    others = {
        seed: [compare(name, folder, args.pairs, seed, params) for name in MAPS]
        for seed in args.other_seeds
    }
    first_plan_times(folder)  # numba's cache loaded, the files in the OS cache
    runs = [first_plan_times(folder) for _ in range(5)]

    def median(i: int, k: int) -> float:
        return float(np.median([run[i][k] for run in runs]))

    times = [
        (name, size, median(i, 2), median(i, 3), median(i, 4))
        for i, (name, size, *_) in enumerate(runs[0])
    ]
    p = planner.resolve_params("wide", **params)
    lines = [
        MARK,
        "## Robot maps: `wide` against a Nav2-style planner",
        "",
        f"- Date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; machine: {cpu()}; "
        f"Python {platform.python_version()}",
        "- Command: `.venv/bin/python benchmarks/nav2_baseline.py`",
        f"- Robot radius {RADIUS} m on the 0.05 m maps; {args.pairs} seeded start/goal pairs per "
        f"map (seed {args.seed}), traversable, connected, at least a third of the diagonal of the "
        "traversable area's bounding box apart.",
        "- Nav2-style baseline on the same configuration space: inflation cost "
        f"`252 * exp(-{SCALING} * (d - r))` for `r < d <= {INFLATION}` m, a move into a cell costs "
        "`(50 + 0.8 * cost) * step length`, plain Dijkstra, 8-connected, no corner cutting.",
        f"- Ours: preset `wide` (wall_cost meters, wide_weight {p.wide_weight}, wide_distance "
        f"{p.wide_distance} m; defaults {default.wide_weight} and {default.wide_distance} m). "
        "Clearance: distance from a path cell's center to the nearest blocked cell's center.",
        "- Target on every map: median length ratio <= 1.10 and median mean-clearance ratio "
        ">= 1.00.",
        "",
        *table(rows),
        "",
        *(
            f"- Seed {seed} (medians, length / clearance): "
            + ", ".join(
                f"{r.name} {np.median(r.length):.3f} / {np.median(r.clearance):.3f}" for r in other
            )
            for seed, other in others.items()
        ),
        "",
        "Reading the map (YAML + image bytes to occupancy), the analysis (configuration space, "
        "gates, tunnels, wall term) and the first plan (both waves, the path and its figures), "
        f"`wide`, robot radius {RADIUS} m on the 0.05 m maps, 0 on the two small ones, in ms "
        "(medians of 5 runs, in one process, numba's cache warm):",
        "",
        "| map | size (px) | read + parse | analysis | first plan | total |",
        "|---|---|---|---|---|---|",
        *(
            f"| {n} | {size} | {a:.1f} | {b:.1f} | {c:.1f} | {a + b + c:.1f} |"
            for n, size, a, b, c in times
        ),
    ]
    print("\n".join(lines))
    if not args.no_write:
        figure(folder, args.seed)
        old = RESULTS.read_text() if RESULTS.exists() else "# Benchmark results\n"
        head = old.split(MARK)[0].rstrip("\n")
        RESULTS.write_text(head + "\n\n" + "\n".join(lines) + "\n")
        print(f"\nwrote {RESULTS.relative_to(ROOT)}")
    every = rows + [r for other in others.values() for r in other]
    ok = all(np.median(r.length) <= 1.10 and np.median(r.clearance) >= 1.0 for r in every)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())

"""Collisions and arrivals among random-walk obstacles, turn-taking against simultaneous motion.

Every preset runs the same seeded episodes on Moving AI maps (64 x 64 and 128 x 128) with 10, 20
or 40 moving obstacles, once with the obstacles moving before the robot decides (``turns``, the
paper's) and once moving at the same time as the robot (``simultaneous``). It prints a table and,
with ``--write``, puts it in its own section of ``benchmarks/RESULTS.md`` (other sections are
left as they are).

    .venv/bin/python benchmarks/simultaneous.py --write
"""

from __future__ import annotations

import argparse
import datetime as dt
import platform
import re
import subprocess
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

import planner
from planner.stepping.simulation import OBSTACLE_MOTIONS

ROOT = Path(__file__).resolve().parents[1]
#: The Moving AI maps beside the checkout (a git worktree sits one level deeper).
MOVINGAI = next(
    (d for d in (p / "shared" / "maps" / "movingai" for p in ROOT.parents) if d.is_dir()),
    ROOT.parent / "shared" / "maps" / "movingai",
)
RESULTS = ROOT / "benchmarks" / "RESULTS.md"
MAPS = (
    ("random-64-64-10", "random-64-64-10-even-1.scen"),
    ("room-64-64-8", "room-64-64-8-even-1.scen"),
    ("maze-128-128-2", "maze-128-128-2-even-1.scen"),
)
DYNAMIC = (10, 20, 40)
#: (row label, preset, parameter overrides): every preset with its defaults, `wide` with no
#: margin (what the margin buys) and `wfs-mmas` with one (what it costs the paper's decision).
VARIANTS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("`wide`", "wide", {}),
    ("`shortest`", "shortest", {}),
    ("`wfs-mmas`", "wfs-mmas", {}),
    ("`mmas`", "mmas", {}),
    ("`wide`, `dynamic_margin=0`", "wide", {"dynamic_margin": 0}),
    ("`wfs-mmas`, `dynamic_margin=1`", "wfs-mmas", {"dynamic_margin": 1}),
)
PRESETS = tuple(label for label, _, _ in VARIANTS)
SECTION = "## 6. Simultaneous motion"


def episodes(per_map: int) -> list[tuple[str, np.ndarray, planner.Scenario, int, int]]:
    """(map name, grid, scenario line, dynamic obstacles, seed) of every episode: the same for
    every preset and mode. Lines are drawn from each map's upper half of path lengths."""
    out: list[tuple[str, np.ndarray, planner.Scenario, int, int]] = []
    for name, scen in MAPS:
        grid = planner.read_map(MOVINGAI / f"{name}.map")
        lines = planner.read_scen(MOVINGAI / scen)
        long = [ln for ln in lines if ln.optimal >= np.median([x.optimal for x in lines])]
        rng = np.random.default_rng(len(out))
        for i in range(per_map):
            line = long[int(rng.integers(len(long)))]
            out.append((name, grid, line, DYNAMIC[i % len(DYNAMIC)], len(out)))
    return out


def run(per_map: int) -> dict[tuple[str, str], dict[str, Any]]:
    runs = episodes(per_map)
    totals: dict[tuple[str, str], dict[str, Any]] = defaultdict(
        lambda: {"episodes": 0, "reached": 0, "collisions": 0, "steps": 0, "waits": 0,
                 "replans": 0, "collided_episodes": 0, "by_map": defaultdict(lambda: [0, 0, 0])}
    )  # fmt: skip
    for preset, name_of_preset, overrides in VARIANTS:
        for name, grid, line, dynamic, seed in runs:
            p = planner.plan(grid, line.start, line.goal, preset=name_of_preset, **overrides)
            for motion in OBSTACLE_MOTIONS:
                m = planner.run_episode(
                    p, dynamic_count=dynamic, seed=seed, record=False, obstacle_motion=motion
                ).metrics
                t = totals[(preset, motion)]
                t["episodes"] += 1
                t["reached"] += m["reached"]
                t["collisions"] += m["collisions"]
                t["collided_episodes"] += m["collisions"] > 0
                t["steps"] += m["iterations"]
                t["waits"] += m["waits"]
                t["replans"] += m["replans"]
                by = t["by_map"][name]
                by[0] += 1
                by[1] += m["reached"]
                by[2] += m["collisions"]
    return totals


def table(totals: dict[tuple[str, str], dict[str, Any]]) -> list[str]:
    lines = [
        "| preset | obstacles move | episodes | arrived | collisions | per 100 steps "
        "| episodes with one | steps (mean) | waits (mean) | replans (mean) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for preset in PRESETS:
        for motion in OBSTACLE_MOTIONS:
            t = totals[(preset, motion)]
            n = t["episodes"]
            lines.append(
                f"| {preset} | {motion} | {n} | {t['reached'] / n:.1%} | {t['collisions']} "
                f"| {100 * t['collisions'] / max(t['steps'], 1):.2f} "
                f"| {t['collided_episodes']} | {t['steps'] / n:.0f} | {t['waits'] / n:.1f} "
                f"| {t['replans'] / n:.2f} |"
            )
    return lines


def by_map(totals: dict[tuple[str, str], dict[str, Any]]) -> list[str]:
    lines = ["| preset | map | arrived (turns / simultaneous) | collisions (turns / simult.) |"]
    lines.append("|---|---|---|---|")
    for preset in PRESETS:
        for name, _ in MAPS:
            a = totals[(preset, "turns")]["by_map"][name]
            b = totals[(preset, "simultaneous")]["by_map"][name]
            lines.append(f"| {preset} | {name} | {a[1]}/{a[0]} / {b[1]}/{b[0]} | {a[2]} / {b[2]} |")
    return lines


def cpu() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return platform.processor() or "unknown CPU"
    fields = dict(
        (k.strip(), v.strip()) for k, _, v in (ln.partition(":") for ln in out.splitlines())
    )
    return f"{fields.get('Model name', 'unknown CPU')}, {fields.get('CPU(s)', '?')} cores"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-map", type=int, default=70, help="episodes per map")
    parser.add_argument("--write", action="store_true", help="write the RESULTS.md section")
    args = parser.parse_args()
    planner.warm_up()
    t0 = time.perf_counter()
    totals = run(args.per_map)
    elapsed = time.perf_counter() - t0
    n = args.per_map * len(MAPS)
    body = [
        SECTION,
        "",
        f"`benchmarks/simultaneous.py --per-map {args.per_map}`, "
        f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC, {cpu()}, {elapsed:.0f} s.",
        "",
        f"{n} seeded episodes per row: {args.per_map} on each of "
        + ", ".join(f"`{name}`" for name, _ in MAPS)
        + " (start and goal from the map's Moving AI scenario lines of at least median length), "
        f"with {', '.join(map(str, DYNAMIC))} random-walk obstacles in turn; every preset meets "
        "the same episodes. `turns`: the obstacles move, then the robot decides from where they "
        "are (the paper's order). `simultaneous`: the robot decides from where they are at the "
        "tick's start, then all move at once. A collision is the robot ending a tick on an "
        "obstacle's cell or swapping cells with one. Each preset runs with its defaults "
        "(`dynamic_margin` 1 for `wide` and `shortest`, 0 for the paper's presets; "
        "`max_steps` 4 (H + W) + 4 x the plan's cells).",
        "",
        *table(totals),
        "",
        "By map:",
        "",
        *by_map(totals),
    ]
    text = "\n".join(body)
    print(text)
    if args.write:
        old = RESULTS.read_text()
        pattern = re.compile(rf"^{re.escape(SECTION)}\n.*?(?=^## |\Z)", re.S | re.M)
        new = (
            pattern.sub(text + "\n\n", old)
            if pattern.search(old)
            else old.rstrip() + "\n\n" + text + "\n"
        )
        RESULTS.write_text(new.rstrip() + "\n")
        print(f"\nwrote the '{SECTION}' section of {RESULTS.relative_to(ROOT)}")


if __name__ == "__main__":
    main()

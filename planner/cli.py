"""``python -m planner``: plan, run Moving AI scenarios, simulate, run the paper's experiment,
render pictures, or show the bundled demo."""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from planner._errors import PlannerError
from planner.analysis import analyse
from planner.environments import DESCRIPTIONS, environment
from planner.experiment import COMPARISONS, DYNAMIC, compare, run_experiment
from planner.grids import read_map, read_scen
from planner.params import PRESETS, resolve_params
from planner.planning import Plan, plan
from planner.render import render_episode, render_plan
from planner.simulation import run_episode, simulate, warm_up

__all__ = ["main"]

EXAMPLE_MAP = resources.files("planner") / "data" / "example.map"
EXAMPLE_START = (7, 2)
EXAMPLE_GOAL = (7, 26)
TOLERANCE = 1e-3


def main(argv: Sequence[str] | None = None) -> int:
    """The command line, as ``python -m planner`` or the ``planner`` console script runs it."""
    # The console script is named in its usage line; everything else prints the same.
    prog = "planner" if Path(sys.argv[0]).name == "planner" else "python -m planner"
    parser = _parser(prog)
    args = parser.parse_args(argv)
    warm_up()  # so that the times reported are the planner's, not numba's compiler's
    try:
        result: int = args.run(args)
    except PlannerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return result


def _parser(prog: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__)
    sub = parser.add_subparsers(required=True, metavar="COMMAND")

    demo = sub.add_parser("demo", help="plan on the bundled example map and explain the result")
    demo.set_defaults(run=_demo)

    p = sub.add_parser("plan", help="plan on a Moving AI .map file; print the result as JSON")
    _map_args(p)
    p.set_defaults(run=_plan)

    s = sub.add_parser("scen", help="run a Moving AI .scen file; print a JSON summary line")
    s.add_argument("scen", type=Path, help="the .scen file")
    s.add_argument("--map", type=Path, help="the .map file (default: the one named, beside it)")
    s.add_argument("--preset", default="shortest", choices=sorted(PRESETS))
    s.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    s.add_argument("--limit", type=int, help="run N lines, evenly spread over the file")
    s.set_defaults(run=_scen)

    m = sub.add_parser("simulate", help="run one seeded episode among moving obstacles")
    _map_args(m)
    m.add_argument("--dynamic", type=int, default=10, help="number of dynamic obstacles")
    m.add_argument("--seed", type=int, default=0)
    m.add_argument("--max-steps", type=int)
    m.set_defaults(run=_simulate)

    e = sub.add_parser("experiment", help="the paper's experiment: six environments, Table 1")
    e.add_argument("--episodes", type=int, default=10, help="seeded episodes per row")
    e.add_argument("--seed", type=int, default=0, help="seeds the maps and the episodes")
    e.add_argument("--dynamic", type=int, default=DYNAMIC, help="dynamic obstacles per episode")
    e.add_argument("--json", action="store_true", help="print the rows as one JSON list")
    e.set_defaults(run=_experiment)

    r = sub.add_parser("render", help="draw a map, its analysis and a plan as PNG (and a GIF)")
    r.add_argument("map", help="a Moving AI .map file, or envN[:SEED] for generated environment N")
    r.add_argument("--start", type=int, nargs=2, required=True, metavar=("R", "C"))
    r.add_argument("--goal", type=int, nargs=2, required=True, metavar=("R", "C"))
    r.add_argument("--preset", default="wide", choices=sorted(PRESETS))
    r.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    r.add_argument("--out", type=Path, required=True, help="the PNG file to write")
    r.add_argument("--field", choices=["clean", "kw"], help="heat map under the free cells")
    r.add_argument("--cell", type=int, default=10, help="pixels per map cell")
    r.add_argument("--animate", type=Path, metavar="FILE.gif", help="also write an episode GIF")
    r.add_argument("--dynamic", type=int, default=DYNAMIC, help="dynamic obstacles (--animate)")
    r.add_argument("--seed", type=int, default=0, help="the episode's seed (--animate)")
    r.set_defaults(run=_render)
    return parser


def _map_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("map", type=Path, help="a Moving AI .map file")
    p.add_argument("--start", type=int, nargs=2, required=True, metavar=("R", "C"))
    p.add_argument("--goal", type=int, nargs=2, required=True, metavar=("R", "C"))
    p.add_argument("--preset", default="wide", choices=sorted(PRESETS))
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")


def _params(pairs: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for pair in pairs:
        name, sep, text = pair.partition("=")
        if not sep:
            raise SystemExit(f"--param takes NAME=VALUE; got {pair!r}")
        try:
            out[name] = json.loads(text)
        except json.JSONDecodeError:
            out[name] = text
    return out


def _plan(args: argparse.Namespace) -> int:
    result = plan(
        read_map(args.map), args.start, args.goal, preset=args.preset, **_params(args.param)
    )
    print(json.dumps(result.summary()))
    return 0


def _simulate(args: argparse.Namespace) -> int:
    episode = simulate(
        read_map(args.map),
        args.start,
        args.goal,
        preset=args.preset,
        dynamic=args.dynamic,
        seed=args.seed,
        max_steps=args.max_steps,
        **_params(args.param),
    )
    print(json.dumps(episode.metrics))
    return 0


def _scen(args: argparse.Namespace) -> int:
    lines = read_scen(args.scen)
    if not lines:
        raise SystemExit(f"{args.scen} holds no scenario lines")
    if args.limit is not None and args.limit < len(lines):
        picks = np.linspace(0, len(lines) - 1, max(args.limit, 1)).round().astype(int)
        lines = [lines[i] for i in sorted(set(picks.tolist()))]
    map_path = args.map or args.scen.parent / Path(lines[0].map_name).name
    grid = read_map(map_path)
    p = resolve_params(args.preset, **_params(args.param))
    analysis = analyse(
        grid, seal_tunnels=p.seal_tunnels, clean_weight=p.clean_weight, clean_radius=p.clean_radius
    )
    solved = mismatches = 0
    max_err = 0.0
    total = 0.0
    for line in lines:
        t0 = time.perf_counter()
        try:
            result: Plan | None = plan(
                None,
                line.start,
                line.goal,
                preset=args.preset,
                analysis=analysis,
                **_params(args.param),
            )
        except PlannerError:
            result = None
        total += time.perf_counter() - t0
        if result is None:
            mismatches += 1
            max_err = float("inf")
            continue
        solved += 1
        err = abs(result.length - line.optimal)
        max_err = max(max_err, err)
        mismatches += err > TOLERANCE
    summary = {
        "scen": str(args.scen),
        "map": str(map_path),
        "preset": args.preset,
        "lines": len(lines),
        "solved": solved,
        "mismatches": mismatches,
        "max_abs_error": max_err if max_err != float("inf") else None,
        "mean_ms": round(total / len(lines) * 1e3, 3),
    }
    print(json.dumps(summary))
    return 1 if mismatches and args.preset == "shortest" else 0


def _experiment(args: argparse.Namespace) -> int:
    rows = run_experiment(episodes=args.episodes, seed=args.seed, dynamic=args.dynamic)
    if args.json:
        print(json.dumps(rows))
        return 0
    print(
        f"The paper's experiment: 6 environments x 5 start/goal pairs (Table 1) x 4 presets, "
        f"{args.episodes} episodes each among {args.dynamic} moving obstacles, seed {args.seed}."
    )
    for number, text in DESCRIPTIONS.items():
        print(f"  env {number}: {text}")
    print("\nMeans over the episodes (collisions: total). time: planning + episode compute, ms.\n")
    print(_table(rows))
    print("\nSummary: the change of the averages over all 30 start/goal pairs.")
    for preset, baseline in COMPARISONS:
        c = compare(rows, preset, baseline)
        print(
            f"  {preset} vs {baseline}: path cost {c['arc_cost']:+.2f}%, "
            f"iterations {c['iterations']:+.2f}%, length {c['path_length']:+.2f}%, "
            f"mean clearance {c['mean_clearance']:+.2f}%, min clearance {c['min_clearance']:+.2f}%"
        )
    print("  (the paper: wfs-mmas vs mmas path cost +11.35%, iterations +7.10%)")
    return 0


def _table(rows: list[dict[str, Any]]) -> str:
    head = (
        f"{'env':>3} {'preset':<9}{'start':>8}{'goal':>8}{'gates':>6}{'tunnels':>8}"
        f"{'iters':>7}{'arc cost':>10}{'time':>7}{'length':>8}{'min cl':>7}{'mean cl':>8}"
        f"{'coll':>5}{'success':>8}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['environment']:>3} {r['preset']:<9}{_pair(r['start']):>8}{_pair(r['goal']):>8}"
            f"{r['gates']:>6}{r['tunnels']:>8}{r['iterations']:>7.1f}{r['arc_cost']:>10.1f}"
            f"{r['time_ms']:>7.2f}{r['path_length']:>8.2f}{r['min_clearance']:>7.2f}"
            f"{r['mean_clearance']:>8.2f}{r['collisions']:>5}{r['success']:>8.0%}"
        )
    return "\n".join(lines)


def _pair(cell: list[int]) -> str:
    return f"{cell[0]},{cell[1]}"


def _render(args: argparse.Namespace) -> int:
    grid = _map_or_environment(args.map)
    result = plan(grid, args.start, args.goal, preset=args.preset, **_params(args.param))
    args.out.write_bytes(render_plan(result, field=args.field, cell=args.cell))
    print(f"wrote {args.out}")
    if args.animate is not None:
        episode = run_episode(result, dynamic=args.dynamic, seed=args.seed)
        args.animate.write_bytes(render_episode(episode, cell=args.cell))
        print(f"wrote {args.animate}: {json.dumps(episode.metrics)}")
    return 0


def _map_or_environment(text: str) -> np.ndarray:
    name, _, seed = text.partition(":")
    if name.startswith("env") and name[3:].isdigit() and (not seed or seed.isdigit()):
        return environment(int(name[3:]), seed=int(seed or 0))
    return read_map(text)


def _demo(args: argparse.Namespace) -> int:
    grid = read_map(Path(str(EXAMPLE_MAP)))
    wide = plan(grid, EXAMPLE_START, EXAMPLE_GOAL, preset="wide")
    short = plan(grid, EXAMPLE_START, EXAMPLE_GOAL, preset="shortest")
    print(
        f"The bundled example map ({grid.shape[0]} x {grid.shape[1]}), "
        f"start S {EXAMPLE_START}, goal G {EXAMPLE_GOAL}."
    )
    print("'#' obstacle, '~' tight-tunnel cell (sealed by `wide`), '*' the `wide` path,")
    print("'+' the `shortest` path, 'x' both.\n")
    print(_ascii(grid, wide, short))
    print()
    for name, p in (("wide", wide), ("shortest", short)):
        print(
            f"{name:>8}: length {p.length:6.2f}, moves {len(p.path) - 1:3d}, "
            f"min clearance {p.min_clearance:.2f}, mean clearance {p.mean_clearance:.2f}, "
            f"touching obstacles on {p.contact_ratio:.0%} of its cells"
        )
    print(
        f"\nThe analysis found {wide.tunnels} tight-tunnel cells and {wide.gates} gates. "
        "`shortest` slips through the one-cell corridor;\n`wide` seals it and crosses the open "
        f"room instead, {wide.length / short.length - 1:.0%} longer, keeping away from walls."
    )
    print("\nTry: python -m planner plan MAP --start R C --goal R C (see README.md).")
    return 0


def _ascii(grid: np.ndarray, wide: Plan, short: Plan) -> str:
    chars = np.where(grid == 1, "#", ".").astype("<U1")
    chars[wide.analysis.state == 2] = "~"
    on_wide = np.zeros(grid.shape, dtype=bool)
    on_wide[wide.path[:, 0], wide.path[:, 1]] = True
    on_short = np.zeros(grid.shape, dtype=bool)
    on_short[short.path[:, 0], short.path[:, 1]] = True
    chars[on_wide] = "*"
    chars[on_short] = "+"
    chars[on_wide & on_short] = "x"
    chars[wide.start] = "S"
    chars[wide.goal] = "G"
    return "\n".join("".join(row) for row in chars)

"""``python -m planner experiment``: the paper's experiment (six environments, Table 1), its
summary seed by seed and the paper's claims checked."""

from __future__ import annotations

import argparse
import json
from typing import Any

from planner.experiment.environments import DESCRIPTIONS
from planner.experiment.runs import DYNAMIC, PAPER_WEIGHTS, SEEDS, Spread, run_experiment, summarise

__all__ = ["add_experiment_command"]


def add_experiment_command(sub: Any) -> None:
    """The ``experiment`` command on ``sub`` (the main parser's subparsers)."""
    e = sub.add_parser("experiment", help="the paper's experiment: six environments, Table 1")
    e.add_argument("--episodes", type=int, default=3, help="seeded episodes per row")
    e.add_argument(
        "--seeds", type=int, nargs="+", default=list(SEEDS), metavar="SEED",
        help="map seeds of every environment (default: 0-9); they seed the episodes too",
    )  # fmt: skip
    e.add_argument(
        "--dynamic-count", type=int, default=DYNAMIC, help="dynamic obstacles per episode"
    )
    e.add_argument("--json", action="store_true", help="print the rows as one JSON list")
    e.add_argument("--rows", action="store_true", help="also print every row")
    e.set_defaults(run=_experiment)


def _experiment(args: argparse.Namespace) -> int:
    rows = run_experiment(
        episodes=args.episodes, seeds=args.seeds, dynamic_count=args.dynamic_count
    )
    if args.json:
        print(json.dumps(rows))
        return 0
    n = len(args.seeds)
    weights = ", ".join(f"env {k}: alpha {a:g}, beta {b:g}" for k, (a, b) in PAPER_WEIGHTS.items())
    print(
        f"The paper's experiment: 6 environments x 5 start/goal pairs (Table 1) x 4 presets on "
        f"{n} map seeds ({_seeds(args.seeds)}), {args.episodes} episodes per row among "
        f"{args.dynamic_count} moving obstacles. Paper presets: {weights}; elsewhere alpha 3, "
        "beta 1."
    )
    for number, text in DESCRIPTIONS.items():
        print(f"  env {number}: {text}")
    if args.rows:
        print("\nMeans over the episodes (collisions: total). time: planning + episode, ms.\n")
        print(_table(rows))
    s = summarise(rows)
    print(
        f"\nEach figure is computed once per map seed (the change of the averages over the 30 "
        f"pairs, the paper's way), then given as median [IQR q1 .. q3; range] over the {n} seeds."
    )
    names = {
        "arc_cost": "path cost",
        "iterations": "iterations",
        "path_length": "length",
        "mean_clearance": "mean clearance",
        "min_clearance": "min clearance",
    }
    for (preset, baseline), figures in s["comparisons"].items():
        print(f"\n  {preset} vs {baseline}:")
        for key, name in names.items():
            print(f"    {name:<15} {figures[key]}")
    if s["environments"]:
        print("\n  wfs-mmas vs mmas by environment (path cost; iterations; mean clearance):")
        for number, figures in s["environments"].items():
            print(
                f"    env {number}: {figures['arc_cost']}; {figures['iterations'].median:+.1f}%; "
                f"{figures['mean_clearance'].median:+.1f}%"
            )
    print("\n  Tunnel cells per environment, median [IQR] (range); most / fewest on N seeds:")
    for number, t in s["tunnels"].items():
        most = s["rank"]["most_tunnels"][number]
        fewest = s["rank"]["fewest_tunnels"][number]
        print(
            f"    env {number}: {t.median:g} [{t.q1:g} .. {t.q3:g}] ({t.low:g} .. {t.high:g}); "
            f"most on {most}/{n}, fewest on {fewest}/{n}"
        )
    _claims(s, n)
    return 0


def _claims(s: dict[str, Any], n: int) -> None:
    """The paper's headline claims, each checked seed by seed."""
    figures = s["comparisons"].get(("wfs-mmas", "mmas"))
    if figures is None:
        return
    cost: Spread = figures["arc_cost"]
    iterations: Spread = figures["iterations"]
    clearance: Spread = figures["mean_clearance"]
    lines = [
        ("path cost higher (the paper: +11.35%)", cost.count(lambda v: v > 0)),
        ("  within 2 points of +11.35%", cost.count(lambda v: abs(v - 11.35) <= 2)),
        ("iterations higher (the paper: +7.10%)", iterations.count(lambda v: v > 0)),
        ("  within 2 points of +7.10%", iterations.count(lambda v: abs(v - 7.10) <= 2)),
        ("mean clearance higher (a wider path)", clearance.count(lambda v: v > 0)),
    ]
    print("\n  The paper's claims (wfs-mmas against mmas), seed by seed:")
    for text, count in lines:
        print(f"    {text:<40} {count}/{n} seeds")
    most = s["rank"]["most_tunnels"].get(1)
    fewest = s["rank"]["fewest_tunnels"].get(6)
    if most is not None and fewest is not None:
        print(f"    {'environment 1 has the most tunnels':<40} {most}/{n} seeds")
        print(f"    {'environment 6 has the fewest tunnels':<40} {fewest}/{n} seeds")
    print("    (baseline [8], D* + PSO, is not implemented; time is not compared:")
    print("    see docs/experiment.md)")


def _seeds(seeds: list[int]) -> str:
    if seeds == list(range(seeds[0], seeds[0] + len(seeds))) and len(seeds) > 2:
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(map(str, seeds))


def _table(rows: list[dict[str, Any]]) -> str:
    head = (
        f"{'seed':>4} {'env':>3} {'preset':<9}{'start':>8}{'goal':>8}{'gates':>6}{'tunnels':>8}"
        f"{'iters':>7}{'arc cost':>10}{'time':>7}{'length':>8}{'min cl':>7}{'mean cl':>8}"
        f"{'coll':>5}{'success':>8}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['seed']:>4} {r['environment']:>3} {r['preset']:<9}"
            f"{_pair(r['start']):>8}{_pair(r['goal']):>8}"
            f"{r['gates']:>6}{r['tunnels']:>8}{r['iterations']:>7.1f}{r['arc_cost']:>10.1f}"
            f"{r['time_ms']:>7.2f}{r['path_length']:>8.2f}{r['min_clearance']:>7.2f}"
            f"{r['mean_clearance']:>8.2f}{r['collisions']:>5}{r['success']:>8.0%}"
        )
    return "\n".join(lines)


def _pair(cell: list[int]) -> str:
    return f"{cell[0]},{cell[1]}"

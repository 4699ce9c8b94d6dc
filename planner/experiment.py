"""The paper's experiment (section 4.2, Table 1): every environment, start/goal pair and preset,
over seeded episodes among moving dynamic obstacles, averaged; and its summary comparisons.

>>> rows = run_experiment(episodes=1, environments=[6], pairs=1, presets=["wide", "shortest"])
>>> [(r["environment"], r["preset"], r["start"], r["goal"]) for r in rows]
[(6, 'wide', [48, 49], [1, 49]), (6, 'shortest', [48, 49], [1, 49])]
>>> rows[0]["collisions"], rows[0]["success"]
(0, 1.0)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from planner._errors import InvalidInput, quote
from planner.environments import TABLE1, environment
from planner.params import PRESETS
from planner.planning import plan
from planner.simulation import run_episode

__all__ = ["COMPARISONS", "DYNAMIC", "METRICS", "PRESET_ORDER", "compare", "run_experiment"]

#: Dynamic obstacles per episode: 10 on a 50 x 50 map (about 0.5% of the ~2000 free cells)
#: is the paper's "random placement" regime: they cross the robot's way now and then without
#: walling it in.
DYNAMIC = 10

PRESET_ORDER = ("wfs-mmas", "mmas", "wide", "shortest")

#: Per-row metrics, each the mean over the episodes (``collisions`` the total).
METRICS = (
    "gates",
    "tunnels",
    "iterations",
    "arc_cost",
    "time_ms",
    "path_length",
    "min_clearance",
    "mean_clearance",
    "contact_ratio",
    "waits",
    "replans",
    "collisions",
    "success",
)

#: (preset, baseline) pairs the summary compares: the paper's claim, and ours.
COMPARISONS = (("wfs-mmas", "mmas"), ("wide", "shortest"))


def run_experiment(
    *,
    episodes: int = 3,
    seed: int = 0,
    dynamic: int = DYNAMIC,
    environments: Sequence[int] = tuple(TABLE1),
    pairs: int = 5,
    presets: Sequence[str] = PRESET_ORDER,
) -> list[dict[str, Any]]:
    """One row per environment x start/goal pair x preset, with the metrics averaged over
    ``episodes`` seeded episodes. The map of every environment is ``environment(n, seed=seed)``;
    episode ``i`` of a pair uses the same obstacle seed for every preset, so presets meet the same
    obstacles at the start.
    """
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise InvalidInput(f"episodes must be a positive integer; got {quote(episodes)}")
    if not 1 <= pairs <= 5:
        raise InvalidInput(f"pairs must be in [1, 5]; got {quote(pairs)}")
    unknown = [p for p in presets if p not in PRESETS]
    if unknown:
        raise InvalidInput(f"unknown preset {quote(unknown[0])}; choose from {', '.join(PRESETS)}")
    rows: list[dict[str, Any]] = []
    for number in environments:
        grid = environment(number, seed=seed)
        for index, (start, goal) in enumerate(TABLE1[number][:pairs]):
            seeds = np.random.SeedSequence([seed, number, index]).generate_state(episodes)
            for preset in presets:
                p = plan(grid, start, goal, preset=preset)
                runs = [
                    run_episode(p, dynamic=dynamic, seed=int(s), record=False).metrics
                    for s in seeds
                ]
                rows.append(_row(number, preset, start, goal, p.elapsed_ms, runs))
    return rows


def _row(
    number: int,
    preset: str,
    start: tuple[int, int],
    goal: tuple[int, int],
    plan_ms: float,
    runs: list[dict[str, Any]],
) -> dict[str, Any]:
    def mean(key: str) -> float:
        return float(np.mean([m[key] for m in runs]))

    return {
        "environment": number,
        "preset": preset,
        "start": list(start),
        "goal": list(goal),
        "episodes": len(runs),
        "gates": runs[0]["gates"],
        "tunnels": runs[0]["tunnels"],
        "iterations": round(mean("iterations"), 2),
        "arc_cost": round(mean("arc_cost"), 2),
        # Planning (analysis and wave, once per plan) plus the episode's own compute.
        "time_ms": round(plan_ms + mean("episode_ms"), 2),
        "path_length": round(mean("path_length"), 2),
        "min_clearance": round(mean("min_clearance"), 3),
        "mean_clearance": round(mean("mean_clearance"), 3),
        "contact_ratio": round(mean("contact_ratio"), 3),
        "waits": round(mean("waits"), 2),
        "replans": round(mean("replans"), 2),
        "collisions": int(sum(m["collisions"] for m in runs)),
        "success": round(float(np.mean([m["reached"] for m in runs])), 3),
    }


def compare(rows: Sequence[dict[str, Any]], preset: str, baseline: str) -> dict[str, float]:
    """Percent change of ``preset``'s mean against ``baseline``'s over the start/goal pairs both
    ran: path cost, iterations, length, mean and minimum clearance (the paper's way: the change of
    the averages).

    >>> rows = [{"environment": 1, "start": [0, 0], "goal": [1, 1], "preset": p, "arc_cost": a,
    ...          "iterations": i, "path_length": i, "mean_clearance": m, "min_clearance": m}
    ...         for p, a, i, m in (("a", 110.0, 20, 2.0), ("b", 100.0, 25, 1.0))]
    >>> compare(rows, "a", "b")["arc_cost"], compare(rows, "a", "b")["mean_clearance"]
    (10.0, 100.0)
    """
    keyed = {(r["environment"], tuple(r["start"]), tuple(r["goal"]), r["preset"]): r for r in rows}
    both = [k[:3] for k in keyed if k[3] == preset and (*k[:3], baseline) in keyed]
    if not both:
        raise InvalidInput(f"no start/goal pair was run with both {preset!r} and {baseline!r}")
    out: dict[str, float] = {}
    for key in ("arc_cost", "iterations", "path_length", "mean_clearance", "min_clearance"):
        ours = np.mean([keyed[(*k, preset)][key] for k in both])
        theirs = np.mean([keyed[(*k, baseline)][key] for k in both])
        out[key] = round(float(ours / theirs - 1) * 100, 2)
    return out

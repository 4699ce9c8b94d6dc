"""Abuse against the real service, with its defaults and two API keys: what each hostile request,
connection or heavy-work pattern costs everyone else.

Starts ``python -m service`` (the settings' defaults, the memory store, two API keys: the
attacker's and another tenant's) on a free port and, for each pattern, polls ``/healthz`` every
50 ms on a fresh connection while the pattern runs: the slowest answer (the stall a probe or
another client sees) and the answers that were not 200, beside the server's RSS growth (its peak
during the pattern over its RSS before, measured after the pattern's setup, such as uploading
its big map). Where a pattern is heavy work, the other tenant meanwhile makes small requests
every 0.2 s (a plan on its 60 x 60 map, or a new 10 x 10 map): their slowest answer. The first
row is the quiet service, the same polling with nothing else going on. Targets (issues 24 and
36): no pattern stalls ``/healthz`` over 0.5 s or grows RSS over 300 MB, and the other tenant's
small requests wait at most 1 s.

Run: ``.venv/bin/python benchmarks/abuse.py`` (about fifteen minutes on a loaded 2-vCPU machine;
``--only NAME`` for one row, with the quiet one).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent))
import abuse_heavy as heavy
import abuse_requests as hostile
from abuse_service import Service, cpu_model, rss_mb, watching

STALL_TARGET = 0.5
RSS_TARGET_MB = 300.0
OTHER_TARGET = 1.0


@dataclass(frozen=True)
class Pattern:
    """What a row does: ``attack(service)``, or ``attack(service, setup(service))`` when it has
    a setup (not measured); ``other``, the other tenant's requests meanwhile (a kind of
    :func:`abuse_service.watching`'s), if any."""

    what: str
    attack: Callable[..., str]
    setup: Callable[[Service], str] | None = None
    other: str | None = None


PATTERNS: dict[str, Pattern] = {
    "quiet": Pattern("the quiet service (polling only)", hostile.quiet),
    "alias-bomb": Pattern("YAML alias bomb: 9 levels of 9 aliases, ~480 bytes", hostile.alias_bomb),
    "big-circles": Pattern(
        "a step with 200 circles of 10^6 m on a 1000 x 1000 map",
        hostile.circles(200, 1e6),
        hostile.plan_on_big_map,
    ),
    "many-circles": Pattern(
        "a step with 2,000 circles of 5 m on that map",
        hostile.circles(2000, 5.0),
        hostile.plan_on_big_map,
    ),
    "million-keys": Pattern("POST /plan, a body of 1 M unknown keys", hostile.million_keys),
    "brackets": Pattern("POST /maps, 32 MB of `[` (the largest body)", hostile.brackets),
    "grid-1024": Pattern("POST /maps, a 1024 x 1024 JSON `grid`", hostile.upload(1024, "grid")),
    "grid-2048": Pattern("POST /maps, a 2048 x 2048 JSON `grid`", hostile.upload(2048, "grid")),
    "grid-3800": Pattern("POST /maps, a 3800 x 3800 JSON `grid`", hostile.upload(3800, "grid")),
    "rows-3800": Pattern("POST /maps, 3800 x 3800 Moving AI `rows`", hostile.upload(3800, "rows")),
    "png-3800": Pattern("POST /maps, a 3800 x 3800 PNG and its YAML", hostile.upload(3800, "png")),
    "idle-sockets": Pattern("4,100 idle TCP connections, held 3 s", hostile.idle_sockets),
    "slowloris": Pattern("200 connections trickling header lines, 8 s", hostile.slowloris),
    "huge-header": Pattern("one connection sending a 64 MB header", hostile.huge_header),
    "stream-never-read": Pattern(
        "an event stream never read, 300 steps of ~700 KB events", hostile.stream_never_read
    ),
    "rezone": Pattern(
        "H1: zoning the zoned map again, 20 x 256 speed zones; other: 10 x 10 uploads",
        heavy.rezone,
        other="upload-10",
    ),
    "waypoints": Pattern("M1: 1024 x 1024 map: 8 waypoints, then 64 (twice)", heavy.waypoints),
    "passages-4096": Pattern(
        "M4: passages of a 4096 x 4096 map, 3 `max_width`s at once; other: 60 x 60 plans",
        heavy.passages,
        heavy.rooms_map(heavy.HUGE),
        other="plan-60",
    ),
    "passages-2048": Pattern(
        "M4: the same on 2048 x 2048 (the largest with passages); other: 60 x 60 plans",
        heavy.passages,
        heavy.rooms_map(2048),
        other="plan-60",
    ),
    "plan-4096": Pattern(
        "a first plan on a 4096 x 4096 map (its analysis); other: 60 x 60 plans",
        heavy.first_plan,
        heavy.walled_map,
        other="plan-60",
    ),
    "tolerance": Pattern(
        "`goal_tolerance` 100 m on that map, the goal inside a 3000 x 3000 block; other: 60 x 60 "
        "plans",
        heavy.tolerance,
        heavy.walled_analysed,
        other="plan-60",
    ),
    "wrong-mask": Pattern(
        "a 4096 x 4096 keepout mask (PGM) at 0.1 m for a 0.05 m map",
        heavy.wrong_mask,
        heavy.free_map(heavy.HUGE),
    ),
    "keepouts": Pattern(
        "256 keepout polygons covering a 4096 x 4096 map",
        heavy.keepouts,
        heavy.free_map(heavy.HUGE),
        other="plan-60",
    ),
    "flood": Pattern(
        f"flood: {heavy.FLOOD_CLIENTS} clients uploading 1024 x 1024 maps with a plan, "
        f"{heavy.FLOOD_SECONDS:.0f} s; other: 60 x 60 plans",
        heavy.flood,
        other="plan-60",
    ),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", action="append", choices=sorted(PATTERNS), default=[])
    args = parser.parse_args()
    names = [n for n in PATTERNS if not args.only or n in args.only or n == "quiet"]
    service = Service({})
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"CPU: {cpu_model()}; load average {load}; python -m service with its defaults, ")
    print("memory store, two API keys.\n")
    print(
        "| pattern | answer | took (s) | /healthz max (s) | not 200 | RSS growth (MB) "
        "| other tenant max (s) | met |"
    )
    print("|---|---|---|---|---|---|---|---|")
    try:
        for name in names:
            pattern = PATTERNS[name]
            prepared = pattern.setup(service) if pattern.setup is not None else None
            before = rss_mb(service.process.pid)
            with watching(service, pattern.other) as result:
                t0 = time.monotonic()
                try:
                    if prepared is None:
                        answer = pattern.attack(service)
                    else:
                        answer = pattern.attack(service, prepared)
                except (httpx.HTTPError, KeyError, ValueError) as exc:  # the row says so
                    answer = f"failed: {type(exc).__name__} {str(exc)[:80]}"
                took = time.monotonic() - t0
            watch = result[0]
            grown = watch.peak_rss - before
            met = watch.stall <= STALL_TARGET and grown <= RSS_TARGET_MB and not watch.failures
            met = met and not answer.startswith("failed")
            other = "-"
            if watch.other:
                worst, median = max(watch.other), statistics.median(watch.other)
                codes = ", ".join(f"{n} x {c}" for c, n in sorted(watch.other_statuses.items()))
                other = f"{worst:.3f} (median {median:.3f}; {codes})"
                met = met and worst <= OTHER_TARGET and set(watch.other_statuses) <= {"200", "201"}
            print(
                f"| {pattern.what} | {answer} | {took:.2f} | {watch.stall:.3f} | "
                f"{watch.failures} | {grown:.0f} | {other} | {'yes' if met else 'NO'} |",
                flush=True,
            )
    finally:
        service.stop()
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"\nload average at the end: {load}")


if __name__ == "__main__":
    main()

"""Issue 14's targets, the HTTP ones as issue 21 set them, as the summary table at the top of
``benchmarks/RESULTS.md``.

``rows`` turns one run's measurements into one row per target: the measured ratio (or value),
the absolute figures beside it, the threshold and whether it is met. A figure that was not
measured is not met, and neither is an HTTP figure from a ``wrk`` run with any non-2xx answer
or socket error (on either side of the ratio): such a run is not a result.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

NEAR_BYTES_PER_CELL = 0.17  # 1 % of a whole-map wave's 17 B per cell
HTTP_TARGETS = (  # (store, case of benchmarks/http_steps.py, minimum ratio to the echo)
    ("memory", "c=1, one plan", 0.6),
    ("memory", "c=16, 16 plans", 0.6),
    ("redis", "c=1, one plan", 0.45),
    ("redis", "c=16, 16 plans", 0.45),
)
P99_CASE, P99_MS = "c=16, one plan", 50.0


@dataclass(frozen=True)
class Row:
    target: str
    measured: str  # the figure compared with the threshold
    figures: str  # the absolute figures it comes from
    threshold: str
    met: bool


def _row(target: str, threshold: str, ok: bool, measured: str, figures: str) -> Row:
    return Row(target, measured, figures, threshold, ok)


def _missing(target: str, threshold: str, why: str = "not measured") -> Row:
    return Row(target, why, "", threshold, False)


def _http(results: Sequence[Mapping[str, Any]], store: str, case: str) -> Mapping[str, Any] | None:
    for r in results:
        if r.get("store") == store and r.get("case") == case:
            return r
    return None


def cost(r: Mapping[str, Any]) -> str:
    """The server's CPU a step and a step's throughput per core, beside the echo's."""
    ours, bare = r["ours"], r["bare"]
    if "cpu_us" not in ours or "cpu_us" not in bare:
        return "CPU not measured"
    return (
        f"CPU {ours['cpu_us']:.0f} µs a step ({per_core(ours):.0f} steps/s a core) against "
        f"{bare['cpu_us']:.0f} µs an echo ({per_core(bare):.0f}/s a core)"
    )


def per_core(run: Mapping[str, Any]) -> float:
    """Requests a second one core serves at this CPU cost a request."""
    return 1e6 / max(float(run["cpu_us"]), 1e-9)


def _errors(run: Mapping[str, float]) -> float:
    return float(run.get("errors", 0.0))


def rows(m: Mapping[str, Any]) -> list[Row]:
    """One row per issue-14 target from one run's measurements, any of them missing:

    - ``plans``: ``scale.bench_plans()`` (4096² near and far plans, memory per cell);
    - ``field``: ``run.bench_field(1024, ...)`` (whole-map plan against tcod);
    - ``analysis``: ``scale.bench_analysis()``; ``upload``: ``scale.bench_upload(...)``;
    - ``http``: ``http_steps.run_store(...)``'s rows, both stores (``{"store", "case",
      "ours", "bare"}``, each side a ``wrk`` result with ``rps``, ``p99_ms``, ``errors`` and
      the server's ``cpu_us`` a request).
    """
    out: list[Row] = []
    plans, field = m.get("plans"), m.get("field")
    analysis, upload = m.get("analysis"), m.get("upload")

    target = "1. Memory a near plan keeps, 4096² (goal ~50 cells away, analysis cached)"
    threshold = f"≤ 0.01 of 17 B/cell (≤ {NEAR_BYTES_PER_CELL} B/cell)"
    if plans is None:
        out.append(_missing(target, threshold))
    else:
        worst = float(plans["near_bytes_per_cell_max"])
        out.append(
            _row(
                target, threshold, worst <= NEAR_BYTES_PER_CELL, f"{worst / 17:.4f}",
                f"{worst:.3f} B/cell, worst of the near plans traced "
                f"(median {plans['near_bytes_per_cell']:.3f}); a far plan "
                f"{plans['far_bytes_per_cell']:.1f} B/cell",
            )
        )  # fmt: skip

    target = "2. Whole-map plan (fields `k` and wide together) / tcod `dijkstra2d`, 1024²"
    if field is None:
        out.append(_missing(target, "≤ 0.5"))
    else:
        ratio = float(field["ours_ms"]) / float(field["tcod_ms"])
        out.append(
            _row(
                target, "≤ 0.5", ratio <= 0.5, f"{ratio:.2f}",
                f"{field['ours_ms']:.0f} ms against {field['tcod_ms']:.0f} ms",
            )
        )  # fmt: skip

    target_ratio = "3. Near plan / corner-to-corner plan, 4096², analysis cached"
    target_ms = "3. Near plan, 4096², analysis cached: time"
    if plans is None:
        out.append(_missing(target_ratio, "≤ 0.01"))
        out.append(_missing(target_ms, "≤ 5 ms"))
    else:
        near, far = float(plans["near_ms"]), float(plans["far_ms"])
        out.append(
            _row(
                target_ratio, "≤ 0.01", near / far <= 0.01, f"{near / far:.4f}",
                f"{near:.2f} ms against {far:.0f} ms (medians)",
            )
        )  # fmt: skip
        out.append(
            _row(
                target_ms, "≤ 5 ms", near <= 5.0, f"{near:.2f} ms",
                f"median of {plans['near_plans']} plans, p90 {plans['near_p90_ms']:.2f} ms",
            )
        )  # fmt: skip

    http: Sequence[Mapping[str, Any]] | None = m.get("http")
    for store, case, least in HTTP_TARGETS:
        target = f"4. HTTP steps / echo, {store} store, {case} (`wrk`)"
        threshold = f"≥ {least}"
        r = None if http is None else _http(http, store, case)
        if r is None:
            out.append(_missing(target, threshold))
            continue
        ours, bare = r["ours"], r["bare"]
        errors = _errors(ours) + _errors(bare)
        ratio = float(ours["rps"]) / float(bare["rps"])
        figures = f"{ours['rps']:.0f} steps/s against {bare['rps']:.0f} echoes/s; " + cost(r)
        if errors:
            out.append(_row(target, threshold, False, f"{errors:.0f} errors: no result", figures))
        else:
            out.append(_row(target, threshold, ratio >= least, f"{ratio:.2f}", figures))
    for store in ("memory", "redis"):
        target = f"4. HTTP steps, {store} store, p99 of one plan stepped at c=16 (`wrk`)"
        threshold = f"≤ {P99_MS:.0f} ms"
        r = None if http is None else _http(http, store, P99_CASE)
        if r is None:
            out.append(_missing(target, threshold))
            continue
        ours = r["ours"]
        p99 = float(ours["p99_ms"])
        figures = f"p50 {ours['p50_ms']:.2f} ms, {ours['rps']:.0f} steps/s; " + cost(r)
        if _errors(ours):
            out.append(
                _row(target, threshold, False, f"{_errors(ours):.0f} errors: no result", figures)
            )
        else:
            out.append(_row(target, threshold, p99 <= P99_MS, f"{p99:.1f} ms", figures))

    target = "5. Analysis of a 4096² map / numpy + `scipy.ndimage`"
    if analysis is None:
        out.append(_missing(target, "≤ 1"))
    else:
        ratio = float(analysis["ours_ms"]) / float(analysis["numpy_ms"])
        out.append(
            _row(
                target, "≤ 1", ratio <= 1.0, f"{ratio:.2f}",
                f"{analysis['ours_ms']:.0f} ms against {analysis['numpy_ms']:.0f} ms",
            )
        )  # fmt: skip
    target = "5. Upload of a 4096² map: parsing its rows / numpy lookup"
    if upload is None:
        out.append(_missing(target, "≤ 1"))
    else:
        ratio = float(upload["parse_ms"]) / float(upload["numpy_parse_ms"])
        out.append(
            _row(
                target, "≤ 1", ratio <= 1.0, f"{ratio:.2f}",
                f"{upload['parse_ms']:.0f} ms against {upload['numpy_parse_ms']:.0f} ms; "
                f"the whole `POST /maps` ({upload['mb']:.0f} MB) {upload['ours_s']:.2f} s, "
                f"a bare echo of it {upload['bare_s']:.2f} s",
            )
        )  # fmt: skip
    return out


def table(summary: Sequence[Row]) -> list[str]:
    """The rows as a markdown table, and a line counting the targets met."""
    lines = [
        "| target | measured | absolute figures | threshold | met |",
        "|---|---:|---|---|---|",
    ]
    for r in summary:
        met = "yes" if r.met else "**no**"
        lines.append(f"| {r.target} | {r.measured} | {r.figures} | {r.threshold} | {met} |")
    lines.append("")
    lines.append(f"{sum(r.met for r in summary)} of {len(summary)} targets met in this run.")
    return lines

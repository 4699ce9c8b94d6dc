"""Decoding a 1024 x 1024 map body: stdlib ``json`` against ``orjson``, and parsing its cells.

Run: ``.venv/bin/python benchmarks/json_decode.py``; prints medians and ratios.
"""

from __future__ import annotations

import functools
import json
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import orjson

import planner


def median_ms(fn: Callable[[], Any], repeat: int = 7) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e3


def main() -> None:
    rng = np.random.default_rng(0)
    grid = (rng.random((1024, 1024)) < 0.2).astype(np.uint8)
    rows = ["".join(".@"[v] for v in row) for row in grid.tolist()]
    bodies = {
        "grid": orjson.dumps({"grid": grid.tolist()}),
        "rows": orjson.dumps({"rows": rows}),
    }
    for name, body in bodies.items():
        std = median_ms(functools.partial(json.loads, body))
        fast = median_ms(functools.partial(orjson.loads, body))
        print(
            f"{name}: {len(body) / 1e6:.1f} MB  json {std:.1f} ms  orjson {fast:.1f} ms  "
            f"json/orjson {std / fast:.2f}"
        )
    decoded_rows = orjson.loads(bodies["rows"])["rows"]
    decoded_grid = orjson.loads(bodies["grid"])["grid"]
    print(f"parse_rows: {median_ms(lambda: planner.parse_rows(decoded_rows)):.1f} ms")
    print(f"as_grid:    {median_ms(lambda: planner.as_grid(decoded_grid)):.1f} ms")


if __name__ == "__main__":
    main()

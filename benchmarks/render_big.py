"""The picture of a big map with many gates: how long it takes to draw and compress.

A 4096 x 4096 random map (30% blocked: ~1.5 million gates) at one pixel a cell, the
default for that size. Issue 13 measured 195 s over HTTP; zlib's best effort (``optimize=True``)
was ~100 s of it, now kept for pictures up to ``planner.render.OPTIMIZE_PIXELS``. Run:
``.venv/bin/python benchmarks/render_big.py [--size 4096]``.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

import planner


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--size", type=int, default=4096)
    size = parser.parse_args().size
    grid = (np.random.default_rng(0).random((size, size)) < 0.3).astype(np.uint8)
    t0 = time.perf_counter()
    analysis = planner.analyse(grid)
    print(f"analysis {time.perf_counter() - t0:.2f} s, {len(analysis.gate_cells())} gates")
    t0 = time.perf_counter()
    png = planner.render_map(analysis, cell=1)
    print(f"render {time.perf_counter() - t0:.2f} s, {len(png) / 1e6:.1f} MB of PNG")
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")


if __name__ == "__main__":
    main()

"""A slow, obvious reference for laser scans: a ray crosses a cell when the segment's part
inside the cell's square (clipped exactly, Liang-Barsky) has a length; a scan marks the
cells its returns end in and clears every other cell its rays cross, ray by ray in meters."""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def inside_length(u0: float, v0: float, u1: float, v1: float, i: int, j: int) -> float:
    """How long the segment (u0, v0)-(u1, v1) runs inside the square [i, i+1] x [j, j+1]."""
    lo, hi = 0.0, 1.0
    for p, q in (
        (-(u1 - u0), u0 - i),
        (u1 - u0, i + 1 - u0),
        (-(v1 - v0), v0 - j),
        (v1 - v0, j + 1 - v0),
    ):
        if p == 0:
            if q < 0:
                return -1.0
            continue
        t = q / p
        if p < 0:
            lo = max(lo, t)
        else:
            hi = min(hi, t)
    return (hi - lo) * math.hypot(u1 - u0, v1 - v0) if hi >= lo else -1.0


def crossed(u0: float, v0: float, u1: float, v1: float, least: float) -> set[tuple[int, int]]:
    """The squares (i: column, j: up from the bottom) the segment runs inside for more than
    ``least`` (a negative ``least``: every square it touches)."""
    out = set()
    for i in range(math.floor(min(u0, u1)) - 1, math.floor(max(u0, u1)) + 2):
        for j in range(math.floor(min(v0, v1)) - 1, math.floor(max(v0, v1)) + 2):
            if inside_length(u0, v0, u1, v1, i, j) > least:
                out.add((i, j))
    return out


def trace(
    blocked: np.ndarray, start: Any, ends: Any, hits: Any, least: float
) -> tuple[set[int], set[int]]:
    """The flat cells marked and cleared by rays in grid units (see ``trace_rays``)."""
    H, W = blocked.shape
    marked: set[int] = set()
    cleared: set[int] = set()

    def flat(i: int, j: int) -> int | None:
        r = H - 1 - j
        if 0 <= r < H and 0 <= i < W and not bool(blocked[r, i]):
            return int(r * W + i)
        return None

    for (u1, v1), hit in zip(ends, hits, strict=True):
        end = (math.floor(u1), math.floor(v1))
        for cell in crossed(start[0], start[1], u1, v1, least):
            if hit and cell == end:
                continue
            f = flat(*cell)
            if f is not None:
                cleared.add(f)
        if hit:
            f = flat(*end)
            if f is not None:
                marked.add(f)
    return marked, cleared - marked

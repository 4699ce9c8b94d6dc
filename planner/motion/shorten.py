"""Shortening a path without losing its clearance: greedy shortcuts between its poses, along
Dubins or Reeds-Shepp curves for a car (they keep the turning radius by construction, so the
curvature bound holds), a turn in place, a straight line and a turn for ``diff``. A shortcut
replaces a piece only when it is free, adds no change of direction (nor more turning in place),
and keeps the footprint's clearance at least the piece's least less one cell."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from planner.footprint import FootprintCells
from planner.motion.collide import Grid, densify, footprint_clearance, poses_free
from planner.motion.curves import Curve, dubins, reeds_shepp

__all__ = ["shorten"]


def shorten(
    grid: Grid,
    cells: FootprintCells,
    poses: npt.NDArray[np.float64],
    direction: npt.NDArray[np.int8],
    motion: str,
    radius: float,
    step: float,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]]:
    """``poses`` (grid frame, cells, at most a cell apart) and their ``direction`` with pieces
    replaced by shorter curves of ``radius`` cells (``car``: Dubins, ``car_reverse``:
    Reeds-Shepp), each checked every ``step`` cells."""
    n = len(poses)
    if n < 3:
        return poses, direction
    clear = footprint_clearance(grid, cells, poses) / grid.frame.resolution
    cusp = np.concatenate([[0], np.cumsum(np.diff(direction.astype(np.int64)) != 0)])
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
    out: list[npt.NDArray[np.float64]] = [poses[:1]]
    dirs: list[npt.NDArray[np.int8]] = [direction[:1]]
    i = 0
    while i < n - 1:
        best: tuple[int, npt.NDArray[np.float64], npt.NDArray[np.int8]] | None = None
        gap = 2
        while True:
            j = min(n - 1, i + gap)
            got = _shortcut(grid, cells, poses, i, j, motion, radius, step, clear, cusp, along)
            if got is not None:
                best = (j, *got)
            elif best is not None:
                break
            if j == n - 1 or gap > n:
                break
            gap *= 2
        if best is None:
            out.append(poses[i + 1 : i + 2])
            dirs.append(direction[i + 1 : i + 2])
            i += 1
            continue
        j, piece, piece_dir = best
        out.append(piece[1:])
        dirs.append(piece_dir[1:])
        i = j
    result = np.concatenate(out)
    result_dir = np.concatenate(dirs)
    result_dir[0] = result_dir[1]
    return result, result_dir


def _shortcut(
    grid: Grid,
    cells: FootprintCells,
    poses: npt.NDArray[np.float64],
    i: int,
    j: int,
    motion: str,
    radius: float,
    step: float,
    clear: npt.NDArray[np.float64],
    cusp: npt.NDArray[np.int64],
    along: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]] | None:
    """The curve from pose ``i`` to pose ``j`` sampled at most a cell apart, when it may replace
    the piece between them; else None."""
    if motion == "diff":
        a, b = poses[i], poses[j]
        face = math.atan2(b[1] - a[1], b[0] - a[0])
        first = math.remainder(face - a[2], 2 * math.pi)
        turned = abs(first) + abs(math.remainder(b[2] - a[2] - first, 2 * math.pi))
        was = np.abs(np.angle(np.exp(1j * np.diff(poses[i : j + 1, 2])))).sum()
        if math.dist(a[:2], b[:2]) >= along[j] - along[i] - 1e-6 or turned > was + 1e-9:
            return None
        piece = _turn_and_go(a, b, step, 2 * cells.pad_angle)
        piece_dir = np.ones(len(piece), dtype=np.int8)
    else:
        make = reeds_shepp if motion == "car_reverse" else dubins
        curve: Curve = make(poses[i], poses[j], radius)
        if curve.length >= along[j] - along[i] - 1e-6 or curve.cusps > cusp[j] - cusp[i]:
            return None
        piece, piece_dir = curve.sample(min(1.0, step))
    if not poses_free(grid, cells, densify(piece, step, 2 * cells.pad_angle)).all():
        return None
    least = float(clear[i : j + 1].min())
    if (footprint_clearance(grid, cells, piece) / grid.frame.resolution).min() < least - 1.0:
        return None
    return piece, piece_dir


def _turn_and_go(
    a: npt.NDArray[np.float64], b: npt.NDArray[np.float64], step: float, angle: float
) -> npt.NDArray[np.float64]:
    """Poses from ``a`` to ``b``: turn in place to face ``b``, drive straight to it, turn to
    its heading; at most ``step`` cells and ``angle`` radians apart (and a cell at most)."""
    face = math.atan2(b[1] - a[1], b[0] - a[0])
    first = a[2] + math.remainder(face - a[2], 2 * math.pi)
    last = first + math.remainder(b[2] - first, 2 * math.pi)
    corners = np.array([a, [a[0], a[1], first], [b[0], b[1], first], [b[0], b[1], last]])
    out = densify(corners, min(1.0, step), angle)
    keep = np.ones(len(out), dtype=bool)
    keep[1:] = np.abs(np.diff(out, axis=0)).max(axis=1) > 1e-12
    out = out[keep]
    out[-1] = b
    return out

"""The analysis of a zoned map (docs/zones.md) from its base map's: keepout only adds blocked
cells, so distances only shrink, and only near the keepout. The distance transform is redone in
a window around the keepout cells: as far as the wall term reaches when no cell on its rim is
nearer a keepout cell than its own nearest blocked cell (then none beyond it is either), else as
far as the farthest cell from a blocked one; the cell states, gates and wall
term only where the configuration space changed. Everything else is the base's arrays. The
result equals :func:`~planner.analysis.analyse.analyse_map` of the zoned map, array for array.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis, analysis_params
from planner.analysis.cells import BLOCKED_CELL, FREE, TUNNEL, classify, gate_cells
from planner.analysis.clean import clean_field
from planner.analysis.cspace import CSpace, wall_term
from planner.analysis.distance import squared_distances
from planner.maps.robot_maps import RobotMap
from planner.params import Params

__all__ = ["Window", "rezone_analysis"]

Box = tuple[int, int, int, int]
"""Rows ``[r0, r1)`` and columns ``[c0, c1)``."""

RIM_SLACK = math.sqrt(2.0)
"""How much nearer than its own blocked cell a rim cell may be to a keepout cell before the
window grows: where a straight line from a cell outside to its nearest keepout cell crosses the
rim, the nearest rim cell's center is at most half a cell along and across it, and both
distances change by at most that much each."""


class Window:
    """What :func:`rezone_analysis` redid: the distance transform's ``box`` and the cells whose
    state it reclassified (``state_box``), for the benchmark's note."""

    def __init__(self, box: Box, state_box: Box | None) -> None:
        self.box = box
        self.state_box = state_box

    @property
    def cells(self) -> int:
        r0, r1, c0, c1 = self.box
        return (r1 - r0) * (c1 - c0)


def rezone_analysis(
    base: Analysis, robot_map: RobotMap, params: Params
) -> tuple[Analysis, Window] | None:
    """The analysis of the zoned ``robot_map`` for ``params`` from ``base``, the analysis of
    the map it was zoned from for the same parameters; None when it cannot be derived (another
    shape or parameter key, or a cell ``base`` has blocked that the zoned map does not)."""
    cs = base.cspace
    if (
        cs is None
        or base.shape != robot_map.shape
        or base.params_key != analysis_params(params, robot_map)
        or base.frame != robot_map.frame
    ):
        return None
    t0 = time.perf_counter()
    occ = robot_map.occupancy
    blocked = occ >= cs.occupied_threshold
    if cs.unknown == "blocked":
        blocked |= occ < 0
    was = cs.blocked == 1
    if (was & ~blocked).any():
        return None
    added = blocked & ~was
    H, W = robot_map.shape
    unknown_cells = (occ < 0).astype(np.uint8)
    if not added.any():
        window = Window((0, 0, 0, 0), None)
        space = CSpace(
            blocked=cs.blocked, distance=cs.distance, traversable=cs.traversable,
            unknown_cells=unknown_cells, resolution=cs.resolution, robot_radius=cs.robot_radius,
            unknown=cs.unknown, occupied_threshold=cs.occupied_threshold,
        )  # fmt: skip
        return _analysis(base, space, base.state, base.clean, base.gates, t0, robot_map), window
    rows, cols = np.nonzero(added.any(axis=1))[0], np.nonzero(added.any(axis=0))[0]
    keep: Box = (int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1)
    limit = (cs.robot_radius / cs.resolution) ** 2
    margin = math.ceil((cs.robot_radius + params.wide_distance) / cs.resolution) + 2
    box = _grow(keep, margin, H, W)
    near_sq, near = _near(added, box)
    if not _rim_unaffected(near, cs.distance, box, H, W):
        # No cell is nearer a keepout cell than its own blocked cell beyond the farthest any
        # cell is from a blocked one (the whole map when nothing was blocked).
        farthest = float(cs.distance.max())
        margin = math.ceil(farthest) + 2 if math.isfinite(farthest) else H + W
        box = _grow(keep, margin, H, W)
        near_sq, near = _near(added, box)
    r0, r1, c0, c1 = box
    inner = (slice(r0, r1), slice(c0, c1))
    distance = cs.distance.copy()
    distance[inner] = np.minimum(cs.distance[inner], near)
    traversable = cs.traversable.copy()
    reach = near_sq > limit + 1e-9 * max(1.0, limit)
    traversable[inner] &= reach.astype(np.uint8)
    traversable[inner] &= (~added[inner]).astype(np.uint8)
    new_blocked = blocked.astype(np.uint8)
    for arr in (new_blocked, distance, traversable, unknown_cells):
        arr.flags.writeable = False
    space = CSpace(
        blocked=new_blocked, distance=distance, traversable=traversable,
        unknown_cells=unknown_cells, resolution=cs.resolution, robot_radius=cs.robot_radius,
        unknown=cs.unknown, occupied_threshold=cs.occupied_threshold,
    )  # fmt: skip
    changed = traversable[inner] != cs.traversable[inner]
    state, clean, gates = base.state, base.clean, base.gates
    state_box = None
    if changed.any():
        ch_rows = np.nonzero(changed.any(axis=1))[0]
        ch_cols = np.nonzero(changed.any(axis=0))[0]
        moved: Box = (
            r0 + int(ch_rows[0]), r0 + int(ch_rows[-1]) + 1,
            c0 + int(ch_cols[0]), c0 + int(ch_cols[-1]) + 1,
        )  # fmt: skip
        state, gates, state_box = _restate(base, cs, space, moved)
    if base.wall_cost == "meters":
        clean = base.clean.copy()
        clean[inner] = wall_term(
            distance[inner], traversable[inner], resolution=cs.resolution,
            robot_radius=cs.robot_radius, weight=params.wide_weight,
            wide_distance=params.wide_distance,
        )  # fmt: skip
    elif base.clean_weight > 0 and state_box is not None:
        clean = _reclean(base, state, state_box)
    return _analysis(base, space, state, clean, gates, t0, robot_map), Window(box, state_box)


def _near(
    added: npt.NDArray[np.bool_], box: Box
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float32]]:
    """Distances squared and distances (cells) from each cell of ``box`` to the nearest added
    cell, as :func:`~planner.analysis.cspace.configuration_space` rounds them."""
    r0, r1, c0, c1 = box
    squared = squared_distances(~added[r0:r1, c0:c1], outside_blocked=False)
    return squared, np.sqrt(squared).astype(np.float32)


def _grow(box: Box, margin: int, H: int, W: int) -> Box:
    r0, r1, c0, c1 = box
    return (max(0, r0 - margin), min(H, r1 + margin), max(0, c0 - margin), min(W, c1 + margin))


def _rim_unaffected(
    near: npt.NDArray[np.float32], was: npt.NDArray[np.float32], box: Box, H: int, W: int
) -> bool:
    """Whether every cell on the window's rim (its outermost rows and columns, where the map
    goes on beyond them) is nearer, by ``RIM_SLACK``, its own blocked cell than any keepout
    cell: then no cell beyond the window is nearer a keepout cell either (the cells nearer a
    keepout cell than their blocked cell hold the straight line to that keepout cell)."""
    r0, r1, c0, c1 = box
    sides = []
    if r0 > 0:
        sides.append((near[0], was[r0, c0:c1]))
    if r1 < H:
        sides.append((near[-1], was[r1 - 1, c0:c1]))
    if c0 > 0:
        sides.append((near[:, 0], was[r0:r1, c0]))
    if c1 < W:
        sides.append((near[:, -1], was[r0:r1, c1 - 1]))
    return all(
        bool(np.all(n.astype(np.float64) >= w.astype(np.float64) + RIM_SLACK)) for n, w in sides
    )


def _crop(arr: npt.NDArray[np.uint8], box: Box, fill: int) -> npt.NDArray[np.uint8]:
    """``arr`` over ``box``, which may reach past the map: those cells ``fill``."""
    H, W = arr.shape
    r0, r1, c0, c1 = box
    out = np.full((r1 - r0, c1 - c0), fill, dtype=arr.dtype)
    a0, a1, b0, b1 = max(r0, 0), min(r1, H), max(c0, 0), min(c1, W)
    if a0 < a1 and b0 < b1:
        out[a0 - r0 : a1 - r0, b0 - c0 : b1 - c0] = arr[a0:a1, b0:b1]
    return out


def _restate(
    base: Analysis, was: CSpace, space: CSpace, moved: Box
) -> tuple[npt.NDArray[np.uint8], int, Box]:
    """The cell states and gate count with the cells of ``moved`` (where the configuration
    space changed) and their neighbours reclassified."""
    H, W = base.shape
    outside = 1 if space.unknown == "blocked" else 0
    r0, r1, c0, c1 = moved
    target = (max(r0 - 1, 0), min(r1 + 1, H), max(c0 - 1, 0), min(c1 + 1, W))
    t0, t1, u0, u1 = target
    context = (t0 - 1, t1 + 1, u0 - 1, u1 + 1)
    grid = np.ascontiguousarray(1 - space.traversable, dtype=np.uint8)
    crop = _crop(grid, context, outside)
    sub, _, _ = classify(crop)
    state = base.state.copy()
    state[t0:t1, u0:u1] = sub[1:-1, 1:-1]
    state.flags.writeable = False
    # Gates: the 2 x 2 squares holding a changed cell, counted before and after.
    old = _crop(np.ascontiguousarray(1 - was.traversable, dtype=np.uint8), context, outside)
    gates = base.gates - _gates(old, context, moved, H, W) + _gates(crop, context, moved, H, W)
    return state, gates, target


def _gates(crop: npt.NDArray[np.uint8], context: Box, moved: Box, H: int, W: int) -> int:
    """The gates of ``crop`` (placed at ``context``) whose square lies in the map and holds a
    cell of ``moved``."""
    found = gate_cells(crop)
    if found.size == 0:
        return 0
    top = np.minimum(found[:, 0], found[:, 2]) + context[0]
    left = np.minimum(found[:, 1], found[:, 3]) + context[2]
    r0, r1, c0, c1 = moved
    inside = (top >= 0) & (top + 1 < H) & (left >= 0) & (left + 1 < W)
    touches = (top + 1 >= r0) & (top < r1) & (left + 1 >= c0) & (left < c1)
    return int(np.count_nonzero(inside & touches))


def _reclean(
    base: Analysis, state: npt.NDArray[np.uint8], state_box: Box
) -> npt.NDArray[np.float32]:
    """The paper's ``clean`` field redone within ``clean_radius`` of the reclassified cells."""
    H, W = base.shape
    k = base.clean_radius
    r0, r1, c0, c1 = state_box
    target = (max(r0 - k, 0), min(r1 + k, H), max(c0 - k, 0), min(c1 + k, W))
    t0, t1, u0, u1 = target
    context = (t0 - k, t1 + k, u0 - k, u1 + k)
    cs = base.cspace
    outside = BLOCKED_CELL if cs is None or cs.unknown == "blocked" else FREE
    crop = _crop(state, context, outside)
    sub = clean_field(crop, seal=base.seal_tunnels, weight=base.clean_weight, radius=k)
    clean = base.clean.copy()
    clean[t0:t1, u0:u1] = sub[k:-k, k:-k]
    clean.flags.writeable = False
    return clean


def _analysis(
    base: Analysis,
    space: CSpace,
    state: npt.NDArray[np.uint8],
    clean: npt.NDArray[np.float32],
    gates: int,
    t0: float,
    robot_map: RobotMap,
) -> Analysis:
    """``base`` for the zoned map: its cells, configuration space and frame (its parameters
    kept)."""
    return replace(
        base,
        state=state,
        clean=clean,
        gates=gates,
        tunnels=int(np.count_nonzero(state == TUNNEL)),
        elapsed_ms=(time.perf_counter() - t0) * 1e3,
        frame=robot_map.frame,
        cspace=space,
        plain=robot_map.plain,
        zones=robot_map.zones,
    )

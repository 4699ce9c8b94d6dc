"""The hybrid search (Dolgov et al.'s Hybrid A*, as Nav2's Smac planner runs it) over
``(x, y, heading bin)``: motion primitives from continuous poses, states merged per cell and
heading bin, the footprint checked along every primitive, an analytic Reeds-Shepp, Dubins or
rotate-straight-rotate expansion toward the goal, and the cost of ``wide``: length times one
plus the wall term of the footprint's clearance. Its heuristic is the larger of the goal wave's
wide cost-to-go (on the configuration space of the footprint's inscribed disc: a lower bound)
and the length of the analytic curve.

Everything here is in the grid's frame, in cells (see :mod:`planner.motion.collide`).
"""

from __future__ import annotations

import heapq
import math
import threading
import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numba import njit, types
from numba.typed import Dict

from planner.errors import InvalidInput
from planner.footprint import FootprintCells
from planner.motion.collide import Grid, clearance_at, pose_free_at
from planner.motion.curves import curve_codes, sample_segments, shortest_curve

__all__ = ["MOTIONS", "Costs", "Found", "Primitives", "hybrid_search", "primitives"]

MOTIONS = ("diff", "car", "car_reverse")
"""The motions: ``diff`` (turns in place), ``car`` (forward arcs), ``car_reverse`` (both)."""

STRAIGHT, ARC, ROTATE = 0, 1, 2
EXHAUSTED, FOUND, STOPPED = 0, 1, 2  # how a search ended

HEURISTIC_WEIGHT = 1.5
"""The heuristic's weight (weighted A*: a path at most this much dearer than the best, found
with far fewer nodes where the footprint's wall term outgrows the inscribed disc's that the
wave counts)."""


@dataclass(frozen=True, slots=True)
class Primitives:
    """A motion's primitives from heading 0: ``moves`` rows ``[du, dv, dtheta, length, direction,
    kind]`` (cells, radians; kind ``STRAIGHT``, ``ARC`` or ``ROTATE``), and for each the poses
    its footprint is checked at, ``samples[sample_starts[i]:sample_starts[i + 1]]`` (its end
    last)."""

    moves: npt.NDArray[np.float64]
    samples: npt.NDArray[np.float64]
    sample_starts: npt.NDArray[np.int64]


def primitives(
    motion: str, radius: float, bins: int, *, check_step: float, check_angle: float
) -> Primitives:
    """The primitives of ``motion`` for a turning ``radius`` (cells) on ``bins`` heading bins:
    a straight move and arcs at the radius turning a whole number of bins, each at least a
    cell's diagonal long (so that it leaves its cell); ``diff``: a straight move and turns in
    place by one, six and eighteen bins. Each primitive's footprint is checked every
    ``check_step`` cells and
    ``check_angle`` radians."""
    delta = 2 * math.pi / bins
    rows: list[tuple[float, float, float, float, float, float]] = []
    if motion == "diff":
        rows.append((1.5, 0.0, 0.0, 1.5, 1.0, STRAIGHT))
        # Turns by one bin, six and eighteen (5, 30 and 90 degrees): a corner is a few nodes.
        rows.extend(
            (0.0, 0.0, s * k * delta, 0.0, 1.0, ROTATE) for k in (1, 6, 18) for s in (1.0, -1.0)
        )
    else:
        least = 2 * math.asin(min(1.0, math.sqrt(2) / (2 * radius)))
        turn = max(1, math.ceil(least / delta - 1e-9)) * delta
        arc = radius * turn
        directions = (1.0, -1.0) if motion == "car_reverse" else (1.0,)
        for d in directions:
            rows.append((d * arc, 0.0, 0.0, arc, d, STRAIGHT))
            for side in (1.0, -1.0):
                dtheta = side * turn * d
                du = radius * math.sin(abs(turn)) * d
                dv = side * radius * (1 - math.cos(turn))
                rows.append((du, dv, dtheta, arc, d, ARC))
    samples: list[npt.NDArray[np.float64]] = []
    for du, dv, dtheta, length, d, kind in rows:
        n = max(1, math.ceil(length / check_step), math.ceil(abs(dtheta) / check_angle))
        f = np.arange(1, n + 1) / n
        if kind == ARC:
            a = f * dtheta
            side = 1.0 if dtheta * d > 0 else -1.0
            pts = np.stack(
                [radius * np.sin(np.abs(a)) * d, side * radius * (1 - np.cos(a)), a], axis=1
            )
        else:
            pts = np.stack([f * du, f * dv, f * dtheta], axis=1)
        samples.append(pts)
    starts = np.zeros(len(rows) + 1, dtype=np.int64)
    starts[1:] = np.cumsum([len(s) for s in samples])
    return Primitives(np.array(rows, dtype=np.float64), np.concatenate(samples), starts)


@dataclass(frozen=True, slots=True)
class Costs:
    """What a motion costs: per cell of length ``1 + wall`` with ``wall = wall_weight * (1 -
    s / wall_distance) ** 4`` for a footprint clearance ``s`` (cells) below ``wall_distance``;
    an arc's length times ``arc_penalty``, a reversing one's times ``reverse_penalty``, each
    change of direction ``cusp_penalty`` cells more, a turn in place ``rotate_cost`` cells a
    radian."""

    wall_weight: float
    wall_distance: float
    arc_penalty: float = 1.05
    reverse_penalty: float = 2.0
    cusp_penalty: float = 20.0
    rotate_cost: float = 4.0

    def as_array(self) -> npt.NDArray[np.float64]:
        return np.array(
            [self.wall_weight, self.wall_distance, self.arc_penalty, self.reverse_penalty,
             self.cusp_penalty, self.rotate_cost]
        )  # fmt: skip


@dataclass(frozen=True, slots=True)
class Found:
    """A search's outcome: the chain of nodes from a start (``poses``, ``moves``: the primitive
    reaching each, -1 for the start) and the analytic path's poses and directions that end it
    (empty when no path was found), and how many nodes were expanded."""

    poses: npt.NDArray[np.float64]
    moves: npt.NDArray[np.int64]
    tail: npt.NDArray[np.float64]
    tail_direction: npt.NDArray[np.int8]
    expansions: int
    stopped: bool = False
    """Whether the search ran out of time (else, not found: no way fits)."""
    seconds: float = 0.0
    """How long the search ran (its kernel's compiling left out)."""

    @property
    def found(self) -> bool:
        return len(self.tail) > 0


@njit(cache=True, nogil=True)
def _wall(clear: float, costs: np.ndarray) -> float:
    if costs[1] <= 0.0 or clear >= costs[1]:
        return 0.0
    share = 1.0 - clear / costs[1]
    return costs[0] * share**4


@njit(cache=True, nogil=True)
def _direct(
    x: float, y: float, t: float, gx: float, gy: float, gt: float, has_yaw: bool,
    step: float, angle: float,
) -> np.ndarray:  # fmt: skip
    """Turn in place toward the goal, drive straight to it, turn to its yaw: poses."""
    dist = math.hypot(gx - x, gy - y)
    head = math.atan2(gy - y, gx - x) if dist > 1e-9 else t
    turn1 = (head - t + math.pi) % (2 * math.pi) - math.pi
    turn2 = ((gt - head + math.pi) % (2 * math.pi) - math.pi) if has_yaw else 0.0
    n1 = math.ceil(abs(turn1) / angle)
    n2 = math.ceil(dist / step)
    n3 = math.ceil(abs(turn2) / angle)
    out = np.empty((1 + n1 + n2 + n3, 3))
    out[0, 0], out[0, 1], out[0, 2] = x, y, t
    k = 1
    for j in range(1, n1 + 1):
        out[k, 0], out[k, 1], out[k, 2] = x, y, t + turn1 * j / n1
        k += 1
    for j in range(1, n2 + 1):
        out[k, 0] = x + (gx - x) * j / n2
        out[k, 1] = y + (gy - y) * j / n2
        out[k, 2] = t + turn1
        k += 1
    for j in range(1, n3 + 1):
        out[k, 0], out[k, 1], out[k, 2] = gx, gy, t + turn1 + turn2 * j / n3
        k += 1
    return out


@njit(cache=True, nogil=True)
def _key(u: float, v: float, t: float, H: int, W: int, bins: int) -> int:
    col = math.floor(u)
    row = H - 1 - math.floor(v)
    if not (0 <= row < H and 0 <= col < W):
        return -1
    b = round(t * bins / (2.0 * math.pi)) % bins
    return (row * W + col) * bins + b


@njit(cache=True, nogil=True)
def _search(
    blocked: np.ndarray, distance: np.ndarray, offsets: np.ndarray, starts: np.ndarray,
    reach: float, outside_blocked: bool, edge: np.ndarray, edge_starts: np.ndarray,
    kw: np.ndarray, moves: np.ndarray, samples: np.ndarray, sample_starts: np.ndarray,
    seeds: np.ndarray, goal: np.ndarray, has_yaw: bool, motion: int, radius: float,
    costs: np.ndarray, stop: np.ndarray, step: float, angle: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, np.ndarray, np.ndarray, int]:  # fmt: skip
    H, W = blocked.shape
    bins = starts.shape[0] - 1
    cap = 1 << 14
    pose = np.empty((cap, 3))
    g = np.empty(cap)
    f_of = np.empty(cap)
    parent = np.empty(cap, dtype=np.int64)
    move = np.empty(cap, dtype=np.int64)
    closed = np.zeros(cap, dtype=np.bool_)
    index = Dict.empty(key_type=types.int64, value_type=types.int64)
    heap = [(0.0, 0)]
    heap.pop()
    n = 0
    gx, gy, gt = goal[0], goal[1], goal[2]
    for i in range(seeds.shape[0]):
        k = _key(seeds[i, 0], seeds[i, 1], seeds[i, 2], H, W, bins)
        if k < 0 or k in index:
            continue
        pose[n] = seeds[i]
        g[n], parent[n], move[n] = 0.0, -1, -1
        f_of[n] = 0.0
        index[k] = n
        heapq.heappush(heap, (0.0, n))
        n += 1
    empty = np.empty((0, 3))
    expansions = 0
    status = EXHAUSTED
    while heap:
        f, i = heapq.heappop(heap)
        if closed[i] or f > f_of[i] + 1e-9:
            continue
        closed[i] = True
        expansions += 1
        if (expansions & 63) == 0 and stop[0] != 0:  # the caller's clock ran out
            status = STOPPED
            break
        x, y, t = pose[i, 0], pose[i, 1], pose[i, 2]
        here = -1.0 if parent[i] < 0 else moves[move[i], 4]
        # The analytic expansion: tried more often as the goal nears.
        reach_len = math.hypot(gx - x, gy - y)
        interval = max(1, int(reach_len / 20.0))
        if expansions % interval == 0 or reach_len < 10.0:
            if motion == 0:
                tail = _direct(x, y, t, gx, gy, gt, has_yaw, step, angle)
                tail_dir = np.ones(tail.shape[0], dtype=np.int8)
            else:
                best = shortest_curve(x, y, t, gx, gy, gt, radius, motion == 2)
                tail, tail_dir = sample_segments(
                    x,
                    y,
                    t,
                    curve_codes(int(best[1]), motion == 2),
                    best[2:],
                    radius,
                    min(step, angle * radius),
                )
            # Free, and no nearer the walls than its ends less a cell: the curve is the
            # shortest way, not a wide one, and must not cut a corner the search kept off.
            least = min(
                clearance_at(distance, edge, edge_starts, outside_blocked, x, y, t),
                clearance_at(distance, edge, edge_starts, outside_blocked, gx, gy, gt),
            ) - 1.0  # fmt: skip
            ok = True
            for j in range(1, tail.shape[0]):
                u, v, w = tail[j, 0], tail[j, 1], tail[j, 2]
                if (
                    not pose_free_at(
                        blocked, distance, offsets, starts, reach, outside_blocked, u, v, w
                    )
                    or clearance_at(distance, edge, edge_starts, outside_blocked, u, v, w) < least
                ):
                    ok = False
                    break
            if ok:
                chain = 0
                j = i
                while j >= 0:
                    chain += 1
                    j = parent[j]
                out_pose = np.empty((chain, 3))
                out_move = np.empty(chain, dtype=np.int64)
                j = i
                for m in range(chain - 1, -1, -1):
                    out_pose[m] = pose[j]
                    out_move[m] = move[j]
                    j = parent[j]
                return out_pose, out_move, tail, FOUND, tail_dir, tail, expansions
        c, s = math.cos(t), math.sin(t)
        for p in range(moves.shape[0]):
            kind = int(moves[p, 5])
            direction = moves[p, 4]
            ok = True
            for j in range(sample_starts[p], sample_starts[p + 1]):
                su = x + c * samples[j, 0] - s * samples[j, 1]
                sv = y + s * samples[j, 0] + c * samples[j, 1]
                if not pose_free_at(blocked, distance, offsets, starts, reach, outside_blocked,
                                  su, sv, t + samples[j, 2]):  # fmt: skip
                    ok = False
                    break
            if not ok:
                continue
            nu = x + c * moves[p, 0] - s * moves[p, 1]
            nv = y + s * moves[p, 0] + c * moves[p, 1]
            nt = t + moves[p, 2]
            k = _key(nu, nv, nt, H, W, bins)
            if k < 0:
                continue
            row, col = k // bins // W, (k // bins) % W
            h = kw[row, col]
            if not math.isfinite(h):
                continue
            j = index[k] if k in index else -1  # noqa: SIM401 - numba types get() as Optional
            if j >= 0 and closed[j]:
                continue
            clear = clearance_at(distance, edge, edge_starts, outside_blocked, nu, nv, nt)
            wall = _wall(clear, costs)
            if kind == ROTATE:
                cost = costs[5] * abs(moves[p, 2]) * (1.0 + wall)
            else:
                cost = moves[p, 3] * (1.0 + wall)
                if kind == ARC:
                    cost *= costs[2]
                if direction < 0:
                    cost *= costs[3]
                if here != direction and parent[i] >= 0:
                    cost += costs[4]
            ng = g[i] + cost
            if j >= 0 and ng >= g[j]:
                continue
            near = math.hypot(gx - nu, gy - nv)
            if motion != 0 and near < 8.0 * radius:
                # Near the goal the heading matters more than the wave knows (far off the wave
                # bounds the curve's length well, and the curve costs 48 words to find).
                near = shortest_curve(nu, nv, nt, gx, gy, gt, radius, motion == 2)[0]
            h = max(h, near)
            if j < 0:
                if n == cap:
                    cap *= 2
                    pose = _grow2(pose, cap)
                    g = _grow1(g, cap)
                    f_of = _grow1(f_of, cap)
                    parent = _grow_int(parent, cap)
                    move = _grow_int(move, cap)
                    closed = _grow_bool(closed, cap)
                j = n
                n += 1
                index[k] = j
            pose[j, 0], pose[j, 1], pose[j, 2] = nu, nv, nt
            g[j], parent[j], move[j] = ng, i, p
            f_of[j] = ng + HEURISTIC_WEIGHT * h
            heapq.heappush(heap, (f_of[j], j))
    return (
        empty,
        np.empty(0, dtype=np.int64),
        empty,
        status,
        np.empty(0, dtype=np.int8),
        empty,
        expansions,
    )


@njit(cache=True, nogil=True)
def _grow2(a: np.ndarray, cap: int) -> np.ndarray:
    out = np.empty((cap, a.shape[1]))
    out[: a.shape[0]] = a
    return out


@njit(cache=True, nogil=True)
def _grow1(a: np.ndarray, cap: int) -> np.ndarray:
    out = np.empty(cap)
    out[: a.shape[0]] = a
    return out


@njit(cache=True, nogil=True)
def _grow_int(a: np.ndarray, cap: int) -> np.ndarray:
    out = np.empty(cap, dtype=np.int64)
    out[: a.shape[0]] = a
    return out


@njit(cache=True, nogil=True)
def _grow_bool(a: np.ndarray, cap: int) -> np.ndarray:
    out = np.zeros(cap, dtype=np.bool_)
    out[: a.shape[0]] = a
    return out


def hybrid_search(
    grid: Grid,
    cells: FootprintCells,
    kw: npt.NDArray[np.float64],
    moves: Primitives,
    seeds: npt.NDArray[np.float64],
    goal: tuple[float, float, float],
    *,
    goal_yaw: bool,
    motion: str,
    radius: float,
    costs: Costs,
    seconds: float,
    step: float,
    angle: float,
) -> Found:
    """Search from any of the grid poses ``seeds`` (``(k, 3)``, cost 0) to the grid pose
    ``goal`` (its heading free unless ``goal_yaw``) for ``motion`` with ``moves`` and a turning
    ``radius`` (cells), for at most about ``seconds`` (a clock: the kernel stops at the next
    64 nodes after a timer thread raises its flag); an analytic path is checked every
    ``step`` cells and ``angle`` radians."""
    if motion not in MOTIONS:
        raise InvalidInput(f"motion must be one of {', '.join(MOTIONS)}; got {motion!r}",
                           field="motion")  # fmt: skip
    if kw.shape != grid.blocked.shape:
        msg = f"the wave's shape {kw.shape} is not the map's {grid.blocked.shape}"
        raise InvalidInput(msg, field="kw")
    if motion != "diff" and not radius > 0:
        raise InvalidInput(f"a car's radius must be > 0 cells; got {radius!r}",
                           field="min_turning_radius")  # fmt: skip
    if not seconds > 0:
        raise InvalidInput(f"seconds must be > 0; got {seconds!r}", field="seconds")
    stop = np.zeros(1, dtype=np.uint8)
    args = (
        grid.blocked, grid.distance, cells.offsets, cells.starts, cells.reach,
        grid.outside_blocked, cells.edge, cells.edge_starts,
        np.ascontiguousarray(kw, dtype=np.float64), moves.moves, moves.samples,
        moves.sample_starts, np.ascontiguousarray(seeds, dtype=np.float64),
        np.array(goal, dtype=np.float64), goal_yaw, MOTIONS.index(motion), float(radius),
        costs.as_array(), stop, float(step), float(angle),
    )  # fmt: skip
    # A call with no seed first returns at once, compiled (or loaded) for these arrays' types:
    # the clock is then the search's alone.
    _search(*args[:12], np.empty((0, 3)), *args[13:])
    timer = threading.Timer(seconds, stop.fill, (1,))
    t0 = time.perf_counter()
    timer.start()
    try:
        out = _search(*args)
    finally:
        timer.cancel()
    took = time.perf_counter() - t0
    return Found(out[0], out[1], out[2], out[4], out[6], stopped=out[3] == STOPPED, seconds=took)

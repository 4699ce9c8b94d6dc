"""Slow, obvious references for the poses: clearance by brute force against the blocked cells'
centers (every one near a segment, found through the exact EDT), the greedy line-of-sight
shortcut, and a checker of every rule of API.md's "Poses" section.

Points here are in cells: ``X = col``, ``Y = -row`` (cell centers at whole numbers)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

TIE = 1e-9  # a clearance equal to the bound passes; the radius must be beaten
SQUARE = 0.5  # squared cells: a blocked cell's square lies within half its diagonal of its center
MAX_TURN = math.radians(15.0)


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def to_cells(points: Any, shape: tuple[int, int], res: float, origin: Any) -> np.ndarray:
    """Meters to cells (X = col, Y = -row): the inverse of the ROS formula."""
    xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    ox, oy, yaw = origin
    dx, dy = xy[:, 0] - ox, xy[:, 1] - oy
    u = (math.cos(yaw) * dx + math.sin(yaw) * dy) / res
    v = (-math.sin(yaw) * dx + math.cos(yaw) * dy) / res
    return np.stack([u - 0.5, v - shape[0] + 0.5], axis=1)


def center_m(shape: tuple[int, int], res: float, origin: Any, r: int, c: int) -> np.ndarray:
    ox, oy, yaw = origin
    u, v = (c + 0.5) * res, (shape[0] - 1 - r + 0.5) * res
    return np.array(
        [ox + math.cos(yaw) * u - math.sin(yaw) * v, oy + math.sin(yaw) * u + math.cos(yaw) * v]
    )


class Blocked:
    """The blocked cells' centers (0 in the EDT), and the ring just outside the map when the
    outside counts as blocked."""

    def __init__(self, distance: np.ndarray, outside_blocked: bool) -> None:
        self.distance = np.asarray(distance, dtype=np.float64)
        H, W = self.distance.shape
        pad = np.zeros((H + 2, W + 2), dtype=bool)
        pad[1:-1, 1:-1] = self.distance == 0
        if outside_blocked:
            pad[0, :] = pad[-1, :] = pad[:, 0] = pad[:, -1] = True
        self.pad = pad  # pad[r + 1, c + 1]: cell [r, c] blocked

    def upper(self, X: float, Y: float) -> float:
        """An upper bound of the distance from (X, Y) to the nearest blocked center: the nearest
        cell center's exact distance plus the way to it."""
        H, W = self.distance.shape
        r = min(max(round(-Y), 0), H - 1)
        c = min(max(round(X), 0), W - 1)
        return float(self.distance[r, c]) + math.hypot(X - c, -Y - r)

    def near(self, a: np.ndarray, b: np.ndarray, reach: float) -> np.ndarray:
        """Every blocked center within ``reach`` of the box around a and b, as (X, Y)."""
        H, W = self.distance.shape
        if not math.isfinite(reach):
            reach = H + W + 2.0
        c0 = max(math.floor(min(a[0], b[0]) - reach), -1)
        c1 = min(math.ceil(max(a[0], b[0]) + reach), W)
        r0 = max(math.floor(min(-a[1], -b[1]) - reach), -1)
        r1 = min(math.ceil(max(-a[1], -b[1]) + reach), H)
        rr, cc = np.nonzero(self.pad[r0 + 1 : r1 + 2, c0 + 1 : c1 + 2])
        return np.stack([cc + c0, -(rr + r0)], axis=1).astype(np.float64)

    def segment_d2(self, a: np.ndarray, b: np.ndarray) -> float:
        """The exact least squared distance from segment a-b to a blocked center."""
        reach = min(self.upper(*a), self.upper(*b)) + 1e-6
        pts = self.near(a, b, reach)
        if len(pts) == 0:
            return math.inf
        d = b - a
        L2 = float(d @ d)
        t = np.zeros(len(pts)) if L2 == 0 else np.clip(((pts - a) @ d) / L2, 0.0, 1.0)
        e = a + t[:, None] * d - pts
        return float((e * e).sum(axis=1).min())


def threshold(least: float, radius_cells: float) -> float:
    """The squared clearance every point must keep, in cells: at least the path's least less
    one cell (ties pass), more than the radius, and outside every blocked square."""
    bound = max(least - 1.0, 0.0) if math.isfinite(least) else 0.0
    R2 = radius_cells * radius_cells
    return max(bound * bound * (1 - TIE), R2 + TIE * max(1.0, R2), SQUARE + TIE)


def greedy_shortcut(V: np.ndarray, clear: Any) -> list[int]:
    """From each kept vertex, the next is the last before the first one it cannot see."""
    keep = [0]
    a = 0
    while a < len(V) - 1:
        j = a + 1
        while j + 1 < len(V) and clear(V[a], V[j + 1]):
            j += 1
        keep.append(j)
        a = j
    return keep


def polyline_length(P: np.ndarray) -> float:
    return float(np.hypot(*np.diff(P, axis=0).T).sum()) if len(P) > 1 else 0.0


@dataclass
class Check:
    """What the checker found: the rules broken (none when all hold) and the figures."""

    problems: list[str] = field(default_factory=list)
    length_m: float = 0.0
    grid_length_m: float = 0.0
    shortcut_length_m: float = 0.0
    min_clearance_m: float = 0.0
    grid_min_clearance_m: float = 0.0
    turning: float = 0.0  # radians, as the robot moves (not its turns in place)
    grid_turning: float = 0.0


def check_poses(
    poses: Any,
    path: Any,
    distance: Any,
    *,
    resolution: float = 1.0,
    origin: Any = (0.0, 0.0, 0.0),
    robot_radius: float = 0.0,
    start: Any = None,
    goal: Any = None,
    start_yaw: float | None = None,
    goal_yaw: float | None = None,
    outside_blocked: bool = True,
) -> Check:
    """Every rule of the poses, by brute force."""
    out = Check()
    P = np.asarray(poses, dtype=np.float64)
    cells = np.asarray(path, dtype=np.int64).reshape(-1, 2)
    D = np.asarray(distance, dtype=np.float64)
    shape = (int(D.shape[0]), int(D.shape[1]))
    res = float(resolution)
    origin = tuple(float(v) for v in origin)
    blocked = Blocked(D, outside_blocked)
    bad = out.problems.append
    if P.ndim != 2 or P.shape[1] != 3 or len(P) == 0 or not np.isfinite(P).all():
        bad(f"poses are not an (m, 3) array of finite numbers: {P.shape}")
        return out
    centers = np.array([center_m(shape, res, origin, r, c) for r, c in cells.tolist()])
    s = centers[0] if start is None else np.asarray(start, dtype=np.float64)
    g = centers[-1] if goal is None else np.asarray(goal, dtype=np.float64)
    tol = 1e-9 * max(1.0, float(np.abs(P[:, :2]).max()))
    if np.abs(P[0, :2] - s).max() > tol:
        bad(f"first pose {P[0, :2].tolist()} is not the start {s.tolist()}")
    if np.abs(P[-1, :2] - g).max() > tol:
        bad(f"last pose {P[-1, :2].tolist()} is not the goal {g.tolist()}")
    steps = np.hypot(*np.diff(P[:, :2], axis=0).T)
    if (steps > res * (1 + 1e-9)).any():
        bad(f"consecutive poses {steps.max():.6g} m apart, more than {res:g} m")
    # Clearance: every point of the polyline, exactly.
    X = to_cells(P[:, :2], shape, res, origin)
    least = float(D[cells[:, 0], cells[:, 1]].min())
    out.grid_min_clearance_m = least * res
    d2 = min((blocked.segment_d2(X[i], X[i + 1]) for i in range(len(X) - 1)), default=None)
    if d2 is None:
        d2 = blocked.segment_d2(X[0], X[0])
    out.min_clearance_m = math.sqrt(d2) * res
    if not out.min_clearance_m > robot_radius:
        bad(f"clearance {out.min_clearance_m:.9g} m is not more than robot_radius {robot_radius:g}")
    if out.min_clearance_m < out.grid_min_clearance_m - res - 1e-9:
        bad(
            f"clearance {out.min_clearance_m:.9g} m is below the grid path's "
            f"{out.grid_min_clearance_m:.9g} m less one resolution"
        )
    # Headings: the tangent, at most 15 degrees a step, turns in place only at the ends.
    yaw = P[:, 2]
    moving = steps > 1e-9 * res
    turns = np.array([wrap(b - a) for a, b in itertools.pairwise(yaw)])
    if len(turns) and np.abs(turns).max() > MAX_TURN + 1e-9:
        bad(f"heading turns {math.degrees(np.abs(turns).max()):.4f} degrees in one step")
    out.turning = float(np.abs(turns[moving]).sum()) if len(turns) else 0.0
    scale = max(1.0, float(np.abs(X).max()))
    for i in np.flatnonzero(moving):
        d = X[i + 1] - X[i]
        direction = math.atan2(d[1], d[0]) + origin[2]
        off = abs(wrap(direction - yaw[i])) + abs(wrap(yaw[i + 1] - direction))
        # The direction of a very short step is known only to the coordinates' rounding.
        if off > abs(turns[i]) + 1e-6 + 1e-14 * scale / math.hypot(*d):
            bad(f"step {i} goes at {direction:.6f} rad, not between its poses' yaws")
            break
    if moving.any():
        lead = int(np.argmax(moving))
        trail = int(np.argmax(moving[::-1]))
        inner = moving[lead : len(moving) - trail]
        if not inner.all():
            bad("a turn in place between the start and the goal")
        if lead and start_yaw is None:
            bad("a turn in place at the start with no start yaw")
        if trail and goal_yaw is None:
            bad("a turn in place at the goal with no goal yaw")
    if (~moving & (np.abs(turns) < 1e-12)).any():
        bad("two poses alike")
    if start_yaw is not None and abs(wrap(yaw[0] - start_yaw)) > 1e-9:
        bad(f"first yaw {yaw[0]} is not start_yaw {start_yaw}")
    if goal_yaw is not None and abs(wrap(yaw[-1] - goal_yaw)) > 1e-9:
        bad(f"last yaw {yaw[-1]} is not goal_yaw {goal_yaw}")
    # Length: no longer than the grid path, nor than 2 % + one cell over the greedy shortcut.
    out.length_m = float(steps.sum())
    out.grid_length_m = polyline_length(centers)
    offsets = float(np.hypot(*(s - centers[0])) + np.hypot(*(g - centers[-1])))
    if out.length_m > out.grid_length_m + offsets + 1e-9:
        bad(f"length {out.length_m:.6g} m is more than the grid path's {out.grid_length_m:.6g} m")
    T = threshold(least, robot_radius / res)
    V = np.concatenate(
        [
            to_cells(s, shape, res, origin),
            np.stack([cells[:, 1], -cells[:, 0]], 1),
            to_cells(g, shape, res, origin),
        ]
    )
    keep = greedy_shortcut(V, lambda a, b: blocked.segment_d2(a, b) >= T)
    out.shortcut_length_m = polyline_length(V[keep]) * res
    if out.length_m > 1.02 * out.shortcut_length_m + res + 1e-9:
        bad(
            f"length {out.length_m:.6g} m is over 1.02 x the shortcut's "
            f"{out.shortcut_length_m:.6g} m + res"
        )
    moves = np.diff(cells, axis=0)
    headings = [math.atan2(-dr, dc) for dr, dc in moves.tolist() if dr or dc]
    out.grid_turning = float(sum(abs(wrap(b - a)) for a, b in itertools.pairwise(headings)))
    return out


def segment_clear_to_start(
    distance: Any,
    a_m: Any,
    b_m: Any,
    *,
    resolution: float,
    origin: Any,
    threshold2: float,
    outside_blocked: bool = True,
) -> bool:
    """Whether the segment between two points in meters keeps the squared clearance (cells)."""
    D = np.asarray(distance, dtype=np.float64)
    shape = (int(D.shape[0]), int(D.shape[1]))
    a = to_cells(a_m, shape, resolution, origin)[0]
    b = to_cells(b_m, shape, resolution, origin)[0]
    return Blocked(D, outside_blocked).segment_d2(a, b) >= threshold2

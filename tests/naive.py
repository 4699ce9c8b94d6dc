"""Slow, obviously-correct pure-Python references of the kernels, straight from ALGORITHM.md."""

from __future__ import annotations

import heapq
import math
from collections import deque

import numpy as np

FREE, OBSTACLE, TUNNEL = 0, 1, 2
MOVES = [(-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1)]


def blocked(grid: np.ndarray, r: int, c: int) -> bool:
    """Outside the map counts as blocked."""
    H, W = grid.shape
    return not (0 <= r < H and 0 <= c < W) or bool(grid[r, c])


def classify(grid: np.ndarray) -> tuple[np.ndarray, int, int]:
    H, W = grid.shape
    state = np.zeros((H, W), dtype=np.uint8)
    for r in range(H):
        for c in range(W):
            if grid[r, c]:
                state[r, c] = OBSTACLE
            elif (blocked(grid, r - 1, c) and blocked(grid, r + 1, c)) or (
                blocked(grid, r, c - 1) and blocked(grid, r, c + 1)
            ):
                state[r, c] = TUNNEL
    gates = 0
    for r in range(H):
        for c in range(W):
            for dr, dc in ((1, 1), (1, -1)):
                r2, c2 = r + dr, c + dc
                if not (0 <= r2 < H and 0 <= c2 < W) or grid[r, c] or grid[r2, c2]:
                    continue
                if grid[r, c2] and grid[r2, c]:
                    gates += 1
    return state, gates, int((state == TUNNEL).sum())


def clean(state: np.ndarray, seal: bool, weight: float, radius: int) -> np.ndarray:
    H, W = state.shape

    def is_blocked(r: int, c: int) -> bool:
        if not (0 <= r < H and 0 <= c < W):
            return True
        return state[r, c] == OBSTACLE or (seal and state[r, c] == TUNNEL)

    out = np.zeros((H, W))
    for r in range(H):
        for c in range(W):
            if state[r, c] == OBSTACLE:
                continue
            total = 0.0
            for dr in range(-radius, radius + 1):
                for dc in range(-radius, radius + 1):
                    d = max(abs(dr), abs(dc))
                    if d >= 1 and is_blocked(r + dr, c + dc):
                        total += weight / d
            out[r, c] = total
    return out


def legal(passable: np.ndarray, r: int, c: int, dr: int, dc: int) -> bool:
    """Move (r, c) -> (r + dr, c + dc): target passable, no corner cutting."""
    H, W = passable.shape

    def ok(y: int, x: int) -> bool:
        return 0 <= y < H and 0 <= x < W and bool(passable[y, x])

    if not ok(r + dr, c + dc):
        return False
    return not (dr and dc) or (ok(r + dr, c) and ok(r, c + dc))


def wave(
    passable: np.ndarray, goal: tuple[int, int], diagonal_cost: float, penalty: np.ndarray | None
) -> np.ndarray:
    """Dijkstra from the goal: cost-to-go where a move X -> Y costs its length plus penalty(Y)."""
    H, W = passable.shape
    dist = np.full((H, W), math.inf)
    dist[goal] = 0.0
    heap = [(0.0, goal)]
    while heap:
        d, (yr, yc) = heapq.heappop(heap)
        if d > dist[yr, yc]:
            continue
        for dr, dc in MOVES:
            xr, xc = yr + dr, yc + dc
            # X -> Y is the move back from Y.
            if not legal(passable, yr, yc, dr, dc):
                continue
            step = diagonal_cost if dr and dc else 1.0
            nd = d + step + (float(penalty[yr, yc]) if penalty is not None else 0.0)
            if nd < dist[xr, xc]:
                dist[xr, xc] = nd
                heapq.heappush(heap, (nd, (xr, xc)))
    return dist


def reachable(passable: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> bool:
    """Breadth-first search over legal moves (the start may itself be off the passable grid)."""
    seen = {start}
    queue = deque([start])
    while queue:
        r, c = queue.popleft()
        if (r, c) == goal:
            return True
        for dr, dc in MOVES:
            if legal(passable, r, c, dr, dc) and (r + dr, c + dc) not in seen:
                seen.add((r + dr, c + dc))
                queue.append((r + dr, c + dc))
    return False


def neighbourhood(passable: np.ndarray, r: int, c: int) -> list[tuple[int, int]]:
    """The cells a decision at (r, c) reads: (r, c) when passable, and its legal neighbours."""
    cells = [(r, c)] if passable[r, c] else []
    return cells + [(r + dr, c + dc) for dr, dc in MOVES if legal(passable, r, c, dr, dc)]

"""Slow, obviously-correct pure-Python references of the kernels, straight from ALGORITHM.md."""

from __future__ import annotations

import heapq
import math
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from planner.maps.polygons import points_in_polygon

FREE, BLOCKED_CELL, TUNNEL = 0, 1, 2
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
                state[r, c] = BLOCKED_CELL
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
    """Ring by ring: the blocked cells at Chebyshev distance exactly d count 1 / d each."""
    H, W = state.shape

    def is_blocked(r: int, c: int) -> bool:
        if not (0 <= r < H and 0 <= c < W):
            return True
        return state[r, c] == BLOCKED_CELL or (seal and state[r, c] == TUNNEL)

    out = np.zeros((H, W), dtype=np.float32)
    for r in range(H):
        for c in range(W):
            if state[r, c] == BLOCKED_CELL:
                continue
            total = 0.0
            for d in range(1, radius + 1):
                ring = [
                    (r + dr, c + dc)
                    for dr in range(-d, d + 1)
                    for dc in range(-d, d + 1)
                    if max(abs(dr), abs(dc)) == d
                ]
                total += sum(is_blocked(y, x) for y, x in ring) / d
            out[r, c] = weight * total
    return out


def legal(passable: np.ndarray, r: int, c: int, dr: int, dc: int) -> bool:
    """Move (r, c) -> (r + dr, c + dc): target passable, no corner cutting."""
    H, W = passable.shape

    def ok(y: int, x: int) -> bool:
        return 0 <= y < H and 0 <= x < W and bool(passable[y, x])

    if not ok(r + dr, c + dc):
        return False
    return not (dr and dc) or (ok(r + dr, c) and ok(r, c + dc))


def move_masks(passable: np.ndarray) -> np.ndarray:
    """Bit i of each passable cell set when move i from it is legal; 0 off the grid."""
    H, W = passable.shape
    out = np.zeros((H, W), dtype=np.uint8)
    for r in range(H):
        for c in range(W):
            if passable[r, c]:
                out[r, c] = sum(
                    1 << i for i, (dr, dc) in enumerate(MOVES) if legal(passable, r, c, dr, dc)
                )
    return out


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


def gate_cells(grid: np.ndarray) -> set[frozenset[tuple[int, int]]]:
    """Pairs of diagonal free cells whose two shared orthogonal cells are both blocked."""
    H, W = grid.shape
    out = set()
    for r in range(H - 1):
        for c in range(W - 1):
            for x, y, s1, s2 in (
                ((r, c), (r + 1, c + 1), (r, c + 1), (r + 1, c)),
                ((r, c + 1), (r + 1, c), (r, c), (r + 1, c + 1)),
            ):
                if not grid[x] and not grid[y] and grid[s1] and grid[s2]:
                    out.add(frozenset((x, y)))
    return out


def legal_moves(passable: np.ndarray, r: int, c: int, dynamic: set[tuple[int, int]]) -> int:
    """Bit i set when move i is legal with the ``dynamic`` cells blocked too."""
    grid = passable.copy()
    H, W = grid.shape
    for r_, c_ in dynamic:
        if 0 <= r_ < H and 0 <= c_ < W:
            grid[r_, c_] = 0
    return sum(1 << i for i, (dr, dc) in enumerate(MOVES) if legal(grid, r, c, dr, dc))


def cost_here(
    passable: np.ndarray, field: np.ndarray, clean: np.ndarray, r: int, c: int, diagonal: float
) -> float:
    """``field`` at (r, c) if passable, or better through a legal move (paying clean there)."""
    best = float(field[r, c]) if passable[r, c] else math.inf
    for dr, dc in MOVES:
        if legal(passable, r, c, dr, dc):
            step = diagonal if dr and dc else 1.0
            best = min(best, step + float(clean[r + dr, c + dc]) + float(field[r + dr, c + dc]))
    return best


def move_obstacles(
    grid: np.ndarray, obstacles: list[tuple[int, int]], robot: tuple[int, int], u: list[float]
) -> list[tuple[int, int]]:
    """Each obstacle in turn: stay or take a legal move (free static cell, no corner cutting,
    not the robot's cell, not a cell another obstacle holds now), the option ``u`` picks."""
    cells = list(obstacles)
    for j, (r, c) in enumerate(cells):
        options: list[tuple[int, int]] = [(r, c)]
        for dr, dc in MOVES:
            y = (r + dr, c + dc)
            if legal(1 - grid, r, c, dr, dc) and y != robot and y not in cells:
                options.append(y)
        cells[j] = options[min(int(u[j] * len(options)), len(options) - 1)]
    return cells


# --------------------------------------------------------------------------------------------
# Robot maps: map_server's pixel rule, distances and circles, one cell at a time.


def ros_occupancy(
    image: Any, *, mode: str, negate: bool, occupied_thresh: float, free_thresh: float
) -> np.ndarray:
    """map_server's loadMapFromFile, pixel by pixel, from a Pillow image (row 0 at the top)."""
    has_alpha = image.mode in ("LA", "RGBA", "PA") or "transparency" in image.info
    rgba = image.convert("RGBA")
    W, H = image.size
    out = np.zeros((H, W), dtype=np.int8)
    for y in range(H):
        for x in range(W):
            r, g, b, a = rgba.getpixel((x, y))
            channels = [r, g, b]
            if mode == "trinary" and has_alpha:
                channels.append(a)
            shade = sum(channels) / len(channels) / 255.0
            occ = shade if negate else 1.0 - shade
            if mode == "trinary":
                value = 100 if occ > occupied_thresh else 0 if occ < free_thresh else -1
            elif mode == "scale":
                if has_alpha and a != 255:
                    value = -1
                elif occ > occupied_thresh:
                    value = 100
                elif occ < free_thresh:
                    value = 0
                else:
                    value = round((occ - free_thresh) / (occupied_thresh - free_thresh) * 100)
            else:
                v = math.floor(shade * 255 + 0.5)
                value = v if 0 <= v <= 100 else -1
            out[y, x] = value
    return out


def distances(blocked: np.ndarray, *, outside_blocked: bool) -> np.ndarray:
    """From every cell's center to the nearest blocked cell's center, in cells, by brute force
    (the ring of cells just outside the map counts when ``outside_blocked``)."""
    H, W = blocked.shape
    sources = [(int(r), int(c)) for r, c in np.argwhere(blocked)]
    if outside_blocked:
        sources += [(r, -1) for r in range(-1, H + 1)] + [(r, W) for r in range(-1, H + 1)]
        sources += [(-1, c) for c in range(W)] + [(H, c) for c in range(W)]
    out = np.full((H, W), math.inf)
    for r in range(H):
        for c in range(W):
            for sr, sc in sources:
                out[r, c] = min(out[r, c], math.hypot(r - sr, c - sc))
    return out


def cell_center(
    shape: tuple[int, int], resolution: float, origin: Any, r: int, c: int
) -> tuple[float, float]:
    """API.md's frame formula for one cell."""
    ox, oy, yaw = origin
    x = (c + 0.5) * resolution
    y = (shape[0] - 1 - r + 0.5) * resolution
    return (
        ox + math.cos(yaw) * x - math.sin(yaw) * y,
        oy + math.sin(yaw) * x + math.cos(yaw) * y,
    )


def circle_cells(
    shape: tuple[int, int],
    resolution: float,
    origin: Any,
    circles: list[dict[str, float]],
    robot_radius: float,
) -> set[tuple[int, int]]:
    out = set()
    for r in range(shape[0]):
        for c in range(shape[1]):
            x, y = cell_center(shape, resolution, origin, r, c)
            for circle in circles:
                if math.hypot(x - circle["x"], y - circle["y"]) <= circle["radius"] + robot_radius:
                    out.add((r, c))
    return out


def nav2_cost(cost: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> float:
    """The least total of ``(50 + 0.8 * cost(Y)) * step length`` over legal moves (cells of
    infinite cost are not passable), by a textbook Dijkstra."""
    return dijkstra(
        np.isfinite(cost), start, goal,
        lambda y, diagonal: (50.0 + 0.8 * float(cost[y])) * (math.sqrt(2.0) if diagonal else 1.0),
    )  # fmt: skip


def dijkstra(
    passable: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    move_cost: Callable[[tuple[int, int], bool], float],
) -> float:
    """The least total of ``move_cost(Y, diagonal)`` over legal moves from ``start`` to
    ``goal``, by a textbook Dijkstra; inf when the goal cannot be reached."""
    dist = {start: 0.0}
    heap = [(0.0, start)]
    while heap:
        d, (r, c) = heapq.heappop(heap)
        if (r, c) == goal:
            return d
        if d > dist[(r, c)]:
            continue
        for dr, dc in MOVES:
            if not legal(passable, r, c, dr, dc):
                continue
            y = (r + dr, c + dc)
            nd = d + move_cost(y, bool(dr and dc))
            if nd < dist.get(y, math.inf):
                dist[y] = nd
                heapq.heappush(heap, (nd, y))
    return math.inf


def chebyshev(a: tuple[int, int], b: tuple[int, int]) -> int:
    return max(abs(a[0] - b[0]), abs(a[1] - b[1]))


def decide(
    passable: np.ndarray,
    k: np.ndarray,
    kw: np.ndarray,
    clean: np.ndarray,
    cell: tuple[int, int],
    obstacles: list[tuple[int, int]],
    margin: int,
    tabu: set[tuple[int, int]],
    goal: tuple[int, int],
    paper: bool,
    alpha: float,
    beta: float,
    diagonal_cost: float,
    target: tuple[int, int] | None,
) -> tuple[int, str]:
    """(move index or -1, outcome) of ALGORITHM.md §3-4, rule by rule, with no bit masks.

    A neighbour is blocked this step when an obstacle stands within ``margin`` of it; a detour's
    ``target`` is taken when the move is not blocked; the paper decision waits when its
    preferred neighbour (as if there were no dynamic obstacles) is blocked; the wide one takes
    the best unblocked neighbour that is closer; an obstacle on the robot's cell makes it step
    to the neighbour of least contact that no obstacle stands on.
    """
    H, W = passable.shape
    r, c = cell

    def blocked(y: tuple[int, int]) -> bool:
        return any(chebyshev(y, o) <= margin for o in obstacles)

    def occupied(y: tuple[int, int]) -> bool:
        return y in obstacles

    def ok(y: tuple[int, int], dynamic: Callable[[tuple[int, int]], bool] | None) -> bool:
        inside = 0 <= y[0] < H and 0 <= y[1] < W
        return inside and bool(passable[y]) and (dynamic is None or not dynamic(y))

    def legal_move(i: int, dynamic: Callable[[tuple[int, int]], bool] | None) -> bool:
        dr, dc = MOVES[i]
        if not ok((r + dr, c + dc), dynamic):
            return False
        return not (dr and dc) or (ok((r + dr, c), dynamic) and ok((r, c + dc), dynamic))

    def step(i: int) -> float:
        return diagonal_cost if i % 2 else 1.0

    def value(i: int) -> float:
        y = (r + MOVES[i][0], c + MOVES[i][1])
        return step(i) + float(clean[y]) + float(kw[y])

    if target is not None:
        for i, (dr, dc) in enumerate(MOVES):
            if (r + dr, c + dc) != target or blocked(target):
                continue
            if dr and dc and (blocked((r + dr, c)) or blocked((r, c + dc))):
                continue
            return i, "move"
    else:
        here = float(kw[cell]) if passable[cell] else math.inf
        for i in range(8):
            if legal_move(i, None):
                here = min(here, value(i))
        if here == math.inf:
            return -1, "blocked"
        preferred = None
        if paper:
            scores = []
            for i, (dr, dc) in enumerate(MOVES):
                y = (r + dr, c + dc)
                if legal_move(i, None) and y not in tabu and k[y] != math.inf:
                    h = math.sqrt((y[0] - goal[0]) ** 2.0 + (y[1] - goal[1]) ** 2.0)
                    scores.append(((float(k[y]) + float(clean[y])) ** alpha * h**beta, i))
            if scores:
                preferred = min(scores)[1]
                if legal_move(preferred, blocked):
                    return preferred, "move"
        if preferred is None:
            options = [(value(i), i) for i in range(8) if legal_move(i, blocked)]
            if options:
                best = min(options)[1]
                y = (r + MOVES[best][0], c + MOVES[best][1])
                if kw[y] < here:
                    return best, "move"
    if occupied(cell):
        escapes = []
        for i, (dr, dc) in enumerate(MOVES):
            if legal_move(i, occupied) and value(i) != math.inf:
                y = (r + dr, c + dc)
                contact = sum(chebyshev(y, o) == 1 for o in obstacles)
                escapes.append((contact, value(i), i))
        if escapes:
            return min(escapes)[2], "evade"
    return -1, "wait"


def detour_cost(
    passable: np.ndarray,
    clean: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    diagonal_cost: float,
    obstacles: list[tuple[int, int]],
    margin: int,
) -> float:
    """Least cost (move + clean of the cell entered) from ``start`` to ``goal`` by Dijkstra, every
    cell within ``margin`` of an obstacle blocked (the start excepted); inf when cut off."""
    free = passable.copy()
    for o in obstacles:
        for r in range(o[0] - margin, o[0] + margin + 1):
            for c in range(o[1] - margin, o[1] + margin + 1):
                if 0 <= r < free.shape[0] and 0 <= c < free.shape[1]:
                    free[r, c] = 0
    if not free[goal]:
        return math.inf
    return dijkstra(
        free,
        start,
        goal,
        lambda y, diagonal: (diagonal_cost if diagonal else 1.0) + float(clean[y]),
    )


def walk(
    passable: np.ndarray,
    k: np.ndarray,
    kw: np.ndarray,
    clean: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    paper: bool,
    alpha: float,
    beta: float,
    diagonal_cost: float,
) -> list[tuple[int, int]]:
    """The cells the decision visits with no dynamic obstacles, start to goal (the paper's with
    the cells already visited as its tabu list); [] when it stops short."""
    path = [start]
    while path[-1] != goal and len(path) <= 4 * passable.size + 8:
        tabu = set(path) if paper else set()
        i, outcome = decide(
            passable, k, kw, clean, path[-1], [], 0, tabu, goal, paper, alpha, beta,
            diagonal_cost, None,
        )  # fmt: skip
        if outcome != "move":
            return []
        path.append((path[-1][0] + MOVES[i][0], path[-1][1] + MOVES[i][1]))
    return path if path[-1] == goal else []


def neighbourhood(passable: np.ndarray, r: int, c: int) -> list[tuple[int, int]]:
    """The cells a decision at (r, c) reads: (r, c) when passable, and its legal neighbours."""
    cells = [(r, c)] if passable[r, c] else []
    return cells + [(r + dr, c + dc) for dr, dc in MOVES if legal(passable, r, c, dr, dc)]


def in_polygon(x: float, y: float, polygon: Any) -> bool:
    """The even-odd rule by PNPOLY's crossing test, one point."""
    inside = False
    n = len(polygon)
    for i in range(n):
        xi, yi = polygon[i]
        xj, yj = polygon[i - 1]
        if (yi > y) != (yj > y) and x < (xj - xi) * (y - yi) / (yj - yi) + xi:
            inside = not inside
    return inside


def polygon_cells(
    shape: tuple[int, int], resolution: float, origin: Any, polygon: Any
) -> np.ndarray:
    """The cells whose centers (API.md's frame formula) a polygon holds, one cell at a time."""
    out = np.zeros(shape, dtype=bool)
    for r in range(shape[0]):
        for c in range(shape[1]):
            out[r, c] = in_polygon(*cell_center(shape, resolution, origin, r, c), polygon)
    return out


def simple(polygon: Any) -> bool:
    """Whether a polygon is simple: no two edges share a point, but neighbours their vertex,
    checked pair by pair with exact rational arithmetic."""
    from fractions import Fraction

    pts = [(Fraction(x), Fraction(y)) for x, y in polygon]
    n = len(pts)

    def cross(o: Any, a: Any, b: Any) -> Fraction:
        out: Fraction = (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
        return out

    def on(p: Any, q: Any, r: Any) -> bool:
        return all(min(p[k], q[k]) <= r[k] <= max(p[k], q[k]) for k in (0, 1))

    def meet(p: Any, q: Any, c: Any, d: Any) -> bool:
        d1, d2, d3, d4 = cross(p, q, c), cross(p, q, d), cross(c, d, p), cross(c, d, q)
        if ((d1 > 0) != (d2 > 0) and d1 != 0 and d2 != 0) and (
            (d3 > 0) != (d4 > 0) and d3 != 0 and d4 != 0
        ):
            return True
        return (
            (d1 == 0 and on(p, q, c))
            or (d2 == 0 and on(p, q, d))
            or (d3 == 0 and on(c, d, p))
            or (d4 == 0 and on(c, d, q))
        )

    for i in range(n):
        for j in range(i + 1, n):
            p, q, c, d = pts[i], pts[(i + 1) % n], pts[j], pts[(j + 1) % n]
            if j == i + 1 or (i == 0 and j == n - 1):
                # Neighbours: only their shared vertex in common (no folding back).
                shared = q if j == i + 1 else p
                other_a = p if j == i + 1 else q
                other_b = d if j == i + 1 else c
                if cross(shared, other_a, other_b) == 0:
                    u = (other_a[0] - shared[0], other_a[1] - shared[1])
                    v = (other_b[0] - shared[0], other_b[1] - shared[1])
                    if u[0] * v[0] + u[1] * v[1] > 0:
                        return False
                continue
            if meet(p, q, c, d):
                return False
    return True


def speed_limits(zones: Any, points: Any) -> np.ndarray:
    """The speed cap at each ``[x, y]`` point by testing it against every speed zone (the loop
    the service ran on every step before the zones had a speed index)."""
    xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    out = np.full(len(xy), np.inf)
    for zone in zones.speed:
        inside = points_in_polygon(xy, zone.polygon)
        out[inside] = np.minimum(out[inside], zone.max_speed)
    return out

"""Numba kernels of the planner: private, pure functions over numpy arrays and scalars.

Each kernel has one validating public wrapper elsewhere in the package; nothing here checks its
input, raises, or touches Python objects. Cells are flat indices ``r * W + c``; the eight moves are
numbered clockwise from north: N NE E SE S SW W NW.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# Cell states of an analysed map: free, blocked (a static obstacle: "blocked" as in the API), a
# tight tunnel.
FREE = 0
BLOCKED_CELL = 1
TUNNEL = 2  # a tight-tunnel cell: free, but sealed when ``seal_tunnels`` is on

# Decision outcomes.
MOVE = 0
EVADE = 1  # an obstacle entered the robot's cell: step aside, even if not closer
WAIT = 2
BLOCKED = 3  # the goal cannot be reached from here, whatever the dynamic obstacles do

MODE_WIDE = 0
MODE_PAPER = 1

DR = np.array([-1, -1, 0, 1, 1, 1, 0, -1], dtype=np.int64)
DC = np.array([0, 1, 1, 1, 0, -1, -1, -1], dtype=np.int64)

_CLOSED = -2
_OUTSIDE = -1


# --------------------------------------------------------------------------------------------
# Map decoding.


@njit(cache=True, nogil=True)
def _decode_cells(data: np.ndarray, lookup: np.ndarray) -> tuple[np.ndarray, int]:
    """``lookup[data]`` (bytes to cells) and the index of the first byte it maps to 255 (not a
    map character), or -1: one pass where numpy takes two (the lookup, then the search)."""
    n = data.shape[0]
    out = np.empty(n, dtype=np.uint8)
    bad = 0
    for i in range(n):
        v = lookup[data[i]]
        out[i] = v
        bad |= v == 255
    if bad:
        for i in range(n):
            if out[i] == 255:
                return out, i
    return out, -1


# --------------------------------------------------------------------------------------------
# Map analysis (docs/algorithm.md, "World model"): gates, tight tunnels, the clean field.


@njit(cache=True, nogil=True)
def _classify(grid: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Cell states (FREE, BLOCKED_CELL, TUNNEL), the gate count and the tunnel count."""
    H, W = grid.shape
    state = np.empty((H, W), dtype=np.uint8)
    tunnels = 0
    for r in range(H):
        for c in range(W):
            if grid[r, c] != 0:
                state[r, c] = BLOCKED_CELL
                continue
            north = r == 0 or grid[r - 1, c] != 0
            south = r == H - 1 or grid[r + 1, c] != 0
            west = c == 0 or grid[r, c - 1] != 0
            east = c == W - 1 or grid[r, c + 1] != 0
            if (north and south) or (east and west):
                state[r, c] = TUNNEL
                tunnels += 1
            else:
                state[r, c] = FREE
    gates = 0
    for r in range(H - 1):
        for c in range(W - 1):
            a = grid[r, c] == 0
            b = grid[r, c + 1] == 0
            d = grid[r + 1, c] == 0
            e = grid[r + 1, c + 1] == 0
            if (a and e and not b and not d) or (b and d and not a and not e):
                gates += 1
    return state, gates, tunnels


@njit(cache=True, nogil=True)
def _classify_rows(grid: np.ndarray) -> tuple[np.ndarray, int, int]:
    """What :func:`_classify` computes, row by row over padded copies of three rows (the
    outside blocked), every inner loop branch-free along a row."""
    H, W = grid.shape
    state = np.empty((H, W), dtype=np.uint8)
    pad = np.ones((3, W + 2), dtype=np.uint8)  # blocked: rows r - 1, r, r + 1
    for c in range(W):
        pad[2, c + 1] = 1 if grid[0, c] != 0 else 0
    tunnels = 0
    gates = 0
    for r in range(H):
        for c in range(W + 2):
            pad[0, c] = pad[1, c]
            pad[1, c] = pad[2, c]
        if r + 1 < H:
            for c in range(W):
                pad[2, c + 1] = 1 if grid[r + 1, c] != 0 else 0
        else:
            for c in range(W + 2):
                pad[2, c] = 1
        up = pad[0]
        mid = pad[1]
        down = pad[2]
        for c in range(W):
            blocked = mid[c + 1]
            tunnel = (up[c + 1] & down[c + 1]) | (mid[c] & mid[c + 2])
            tunnel &= 1 - blocked
            state[r, c] = blocked * BLOCKED_CELL + tunnel * TUNNEL
            tunnels += tunnel
        if r + 1 < H:
            # A gate: two free cells diagonal to each other, the other two of the square blocked.
            for c in range(W - 1):
                a = mid[c + 1]
                b = mid[c + 2]
                d = down[c + 1]
                e = down[c + 2]
                gates += ((1 - a) & (1 - e) & b & d) | ((1 - b) & (1 - d) & a & e)
    return state, gates, tunnels


@njit(cache=True, nogil=True)
def _gate_cells(grid: np.ndarray) -> np.ndarray:
    """Every gate as a row ``[r1, c1, r2, c2]``: the two free cells of the diagonal gap."""
    H, W = grid.shape
    out = np.empty((max(H - 1, 0) * max(W - 1, 0), 4), dtype=np.int64)
    n = 0
    for r in range(H - 1):
        for c in range(W - 1):
            a = grid[r, c] == 0
            b = grid[r, c + 1] == 0
            d = grid[r + 1, c] == 0
            e = grid[r + 1, c + 1] == 0
            if a and e and not b and not d:
                out[n, 0], out[n, 1], out[n, 2], out[n, 3] = r, c, r + 1, c + 1
                n += 1
            elif b and d and not a and not e:
                out[n, 0], out[n, 1], out[n, 2], out[n, 3] = r, c + 1, r + 1, c
                n += 1
    return out[:n].copy()


@njit(cache=True, nogil=True)
def _clean(state: np.ndarray, seal: bool, weight: float, radius: int) -> np.ndarray:
    """The clean penalty of every non-obstacle cell.

    Each blocked cell (an obstacle, a sealed tunnel cell, or outside the map) at Chebyshev
    distance d, 1 <= d <= radius, adds ``weight / d``. Rings are counted from an integral image,
    so the cost is O(H * W * radius) instead of O(H * W * radius**2).
    """
    H, W = state.shape
    p = radius
    S = np.zeros((H + 2 * p + 1, W + 2 * p + 1), dtype=np.int32)
    for i in range(H + 2 * p):
        r = i - p
        for j in range(W + 2 * p):
            c = j - p
            if r < 0 or r >= H or c < 0 or c >= W:
                v = 1
            else:
                s = state[r, c]
                v = 1 if (s == BLOCKED_CELL or (seal and s == TUNNEL)) else 0
            S[i + 1, j + 1] = S[i, j + 1] + S[i + 1, j] - S[i, j] + v
    out = np.zeros((H, W), dtype=np.float32)
    for r in range(H):
        for c in range(W):
            if state[r, c] == BLOCKED_CELL:
                continue
            i = r + p
            j = c + p
            s = state[r, c]
            prev = 1 if (seal and s == TUNNEL) else 0
            total = 0.0
            for d in range(1, radius + 1):
                box = (
                    S[i + d + 1, j + d + 1]
                    - S[i - d, j + d + 1]
                    - S[i + d + 1, j - d]
                    + S[i - d, j - d]
                )
                total += (box - prev) / d
                prev = box
            out[r, c] = weight * total
    return out


@njit(cache=True, nogil=True)
def _clean_rows(state: np.ndarray, seal: bool, weight: float, radius: int) -> np.ndarray:
    """What :func:`_clean` computes, bit for bit, with separable box sums over a ring of
    2 * radius + 1 rows: per ring distance d, each row's sums over 2d + 1 columns, then their sums
    over 2d + 1 rows; every inner loop runs along a row (the compiler vectorises it) and the
    working set is a few rows, not an integral image of the whole map."""
    H, W = state.shape
    p = radius
    ring = 2 * p + 1
    Wp = W + 2 * p
    blocked = np.ones((ring, Wp), dtype=np.int16)  # padded rows; the outside counts as blocked
    rows = np.empty((radius + 1, ring, W), dtype=np.int16)  # rows[d]: sums over 2d + 1 columns
    box = np.empty(W, dtype=np.int16)
    inner = np.empty(W, dtype=np.int16)
    total = np.empty(W, dtype=np.float64)
    out = np.zeros((H, W), dtype=np.float32)
    for i in range(H + 2 * p):  # padded row i is map row i - p
        slot = i % ring
        r = i - p
        if 0 <= r < H:
            for c in range(W):
                s = state[r, c]
                blocked[slot, c + p] = 1 if (s == BLOCKED_CELL or (seal and s == TUNNEL)) else 0
        else:
            for c in range(Wp):
                blocked[slot, c] = 1
        for c in range(W):
            rows[0, slot, c] = blocked[slot, c + p]
        for d in range(1, radius + 1):
            for c in range(W):
                rows[d, slot, c] = rows[d - 1, slot, c] + blocked[slot, c + p - d]
                rows[d, slot, c] += blocked[slot, c + p + d]
        r = i - 2 * p  # the map row whose window (rows r - p .. r + p) is now complete
        if r < 0:
            continue
        centre = (r + p) % ring
        for c in range(W):
            inner[c] = rows[0, centre, c]
            total[c] = 0.0
        for d in range(1, radius + 1):
            for c in range(W):
                box[c] = rows[d, (r + p - d) % ring, c]
            for k in range(r + p - d + 1, r + p + d + 1):
                slot_k = k % ring
                for c in range(W):
                    box[c] += rows[d, slot_k, c]
            for c in range(W):
                total[c] += (box[c] - inner[c]) / d
                inner[c] = box[c]
        for c in range(W):
            if state[r, c] != BLOCKED_CELL:
                out[r, c] = weight * total[c]
    return out


# --------------------------------------------------------------------------------------------
# An indexed binary min-heap over cell indices (decrease-key in place, no per-push allocation).


@njit(cache=True, nogil=True)
def _sift_up(keys: np.ndarray, items: np.ndarray, pos: np.ndarray, j: int) -> None:
    key = keys[j]
    item = items[j]
    while j > 0:
        parent = (j - 1) >> 1
        if keys[parent] <= key:
            break
        keys[j] = keys[parent]
        items[j] = items[parent]
        pos[items[j]] = j
        j = parent
    keys[j] = key
    items[j] = item
    pos[item] = j


@njit(cache=True, nogil=True)
def _sift_down(keys: np.ndarray, items: np.ndarray, pos: np.ndarray, j: int, size: int) -> None:
    key = keys[j]
    item = items[j]
    while True:
        child = 2 * j + 1
        if child >= size:
            break
        if child + 1 < size and keys[child + 1] < keys[child]:
            child += 1
        if keys[child] >= key:
            break
        keys[j] = keys[child]
        items[j] = items[child]
        pos[items[j]] = j
        j = child
    keys[j] = key
    items[j] = item
    pos[item] = j


@njit(cache=True, nogil=True)
def _push_or_decrease(
    keys: np.ndarray, items: np.ndarray, pos: np.ndarray, size: int, item: int, key: float
) -> int:
    """Insert ``item`` or lower its key; returns the new heap size."""
    j = pos[item]
    if j == _OUTSIDE:
        keys[size] = key
        items[size] = item
        _sift_up(keys, items, pos, size)
        return size + 1
    keys[j] = key
    _sift_up(keys, items, pos, j)
    return size


@njit(cache=True, nogil=True)
def _pop(keys: np.ndarray, items: np.ndarray, pos: np.ndarray, size: int) -> tuple[int, float, int]:
    """Remove the least entry; returns (item, key, new size). The item is marked closed."""
    item = items[0]
    key = keys[0]
    size -= 1
    if size > 0:
        keys[0] = keys[size]
        items[0] = items[size]
        _sift_down(keys, items, pos, 0, size)
    pos[item] = _CLOSED
    return item, key, size


# --------------------------------------------------------------------------------------------
# The goal wave (docs/algorithm.md, "Analysis"): Dijkstra from the goal, best entry expanded first.


@njit(cache=True, nogil=True)
def _move_masks(passable: np.ndarray) -> np.ndarray:
    """Bit i of each passable cell set when move i from it is legal (inside the map, target
    passable, both orthogonal cells of a diagonal passable); 0 for cells that are not passable.
    The wave reads one byte per cell instead of up to three cells and four bounds per move."""
    H, W = passable.shape
    out = np.zeros((H, W), dtype=np.uint8)
    for r in range(H):
        for c in range(W):
            if passable[r, c] == 0:
                continue
            n = r > 0 and passable[r - 1, c] != 0
            s = r < H - 1 and passable[r + 1, c] != 0
            w = c > 0 and passable[r, c - 1] != 0
            e = c < W - 1 and passable[r, c + 1] != 0
            ne = n and e and passable[r - 1, c + 1] != 0
            se = s and e and passable[r + 1, c + 1] != 0
            sw = s and w and passable[r + 1, c - 1] != 0
            nw = n and w and passable[r - 1, c - 1] != 0
            out[r, c] = n | ne << 1 | e << 2 | se << 3 | s << 4 | sw << 5 | w << 6 | nw << 7
    return out


@njit(cache=True, nogil=True)
def _move_masks_rows(passable: np.ndarray) -> np.ndarray:
    """What :func:`_move_masks` computes, row by row over zero-padded copies of three rows, so
    that every inner loop is branch-free along a row (the compiler vectorises it)."""
    H, W = passable.shape
    out = np.zeros((H, W), dtype=np.uint8)
    pad = np.zeros((3, W + 2), dtype=np.uint8)  # rows r - 1, r, r + 1; columns shifted by one
    for c in range(W):
        pad[2, c + 1] = 1 if passable[0, c] != 0 else 0
    for r in range(H):
        for c in range(W + 2):
            pad[0, c] = pad[1, c]
            pad[1, c] = pad[2, c]
        if r + 1 < H:
            for c in range(W):
                pad[2, c + 1] = 1 if passable[r + 1, c] != 0 else 0
        else:
            for c in range(W + 2):
                pad[2, c] = 0
        up = pad[0]
        mid = pad[1]
        down = pad[2]
        for c in range(W):
            n = up[c + 1]
            s = down[c + 1]
            w = mid[c]
            e = mid[c + 2]
            ne = n & e & up[c + 2]
            se = s & e & down[c + 2]
            sw = s & w & down[c]
            nw = n & w & up[c]
            bits = n | ne << 1 | e << 2 | se << 3 | s << 4 | sw << 5 | w << 6 | nw << 7
            out[r, c] = bits * mid[c + 1]
    return out


@njit(cache=True, nogil=True)
def _wave(
    masks: np.ndarray, goal: int, diagonal_cost: float, clean: np.ndarray, use_clean: bool
) -> np.ndarray:
    """Cost-to-go to ``goal`` of every cell: ``k`` (plain) or, with ``use_clean``, ``kw``.

    A move X -> Y costs 1 straight or ``diagonal_cost`` diagonally, plus ``clean(Y)`` for kw;
    ``masks`` (from :func:`_move_masks`) says which moves are legal. Unreachable: +inf.

    Every move costs at least 1, so cells whose cost-to-go has the same integer part cannot
    improve one another: a bucket queue of width 1 may settle each bucket's cells in any order
    and still gives exactly Dijkstra's result, with O(1) pushes, pops and decrease-keys. The
    buckets are doubly linked lists threaded through two arrays, in a ring of a power of two
    (larger than the largest move cost) indexed by ``floor(cost)``.
    """
    H, W = masks.shape
    n = H * W
    moves = masks.ravel()
    pen = clean.ravel()
    largest = max(diagonal_cost, 1.0)
    if use_clean:
        top = 0.0
        for i in range(n):
            if moves[i] and pen[i] > top:
                top = pen[i]
        largest += top
    ring = 1
    while ring < int(largest) + 2:
        ring *= 2
    wrap = ring - 1
    offset = np.empty(8, dtype=np.int64)
    step = np.empty(8, dtype=np.float64)
    for i in range(8):
        offset[i] = DR[i] * W + DC[i]
        step[i] = diagonal_cost if i & 1 else 1.0
    head = np.full(ring, -1, dtype=np.int32)
    nxt = np.empty(n, dtype=np.int32)
    prv = np.empty(n, dtype=np.int32)
    dist = np.full(n, np.inf)
    dist[goal] = 0.0
    head[0] = goal
    nxt[goal] = -1
    prv[goal] = -1
    queued = 1
    bucket = 0
    while queued > 0:
        b = bucket & wrap
        y = head[b]
        while y != -1:
            q = nxt[y]
            head[b] = q
            if q != -1:
                prv[q] = -1
            queued -= 1
            base = dist[y] + pen[y] if use_clean else dist[y]
            m = moves[y]
            for i in range(8):
                if not (m >> i) & 1:
                    continue
                x = y + offset[i]
                nd = base + step[i]
                # A settled cell's cost is below every cost offered to it later: no state needed.
                if nd < dist[x]:
                    if dist[x] < np.inf:  # queued: unlink from its old bucket
                        p = prv[x]
                        q = nxt[x]
                        if p == -1:
                            head[int(dist[x]) & wrap] = q
                        else:
                            nxt[p] = q
                        if q != -1:
                            prv[q] = p
                    else:
                        queued += 1
                    dist[x] = nd
                    t = int(nd) & wrap
                    q = head[t]
                    nxt[x] = q
                    prv[x] = -1
                    if q != -1:
                        prv[q] = x
                    head[t] = x
            y = head[b]
        bucket += 1
    return dist.reshape(H, W)


# --------------------------------------------------------------------------------------------
# Deciding the next move (docs/algorithm.md, "Deciding the next move").


@njit(cache=True, nogil=True)
def _legal_moves(passable: np.ndarray, r: int, c: int, dyn: int) -> int:
    """Bit i set when move i from (r, c) is legal: target passable and not in ``dyn`` (a bit mask
    of dynamically occupied neighbours), and for a diagonal both orthogonal cells likewise."""
    H, W = passable.shape
    ok = 0
    for i in range(8):
        yr = r + DR[i]
        yc = c + DC[i]
        if yr < 0 or yr >= H or yc < 0 or yc >= W or passable[yr, yc] == 0 or (dyn >> i) & 1:
            continue
        if i & 1:
            # The orthogonal cells beside diagonal i are moves i - 1 and i + 1.
            a = (i + 7) & 7
            b = (i + 1) & 7
            if (dyn >> a) & 1 or (dyn >> b) & 1:
                continue
            if passable[r + DR[a], c + DC[a]] == 0 or passable[r + DR[b], c + DC[b]] == 0:
                continue
        ok |= 1 << i
    return ok


@njit(cache=True, nogil=True)
def _wide_value(
    kw: np.ndarray, clean: np.ndarray, r: int, c: int, i: int, diagonal_cost: float
) -> float:
    """``cost(X, Y) + clean(Y) + kw(Y)`` for the move i from X = (r, c)."""
    yr = r + DR[i]
    yc = c + DC[i]
    step = diagonal_cost if i & 1 else 1.0
    return step + clean[yr, yc] + kw[yr, yc]


@njit(cache=True, nogil=True)
def _cost_here(
    passable: np.ndarray,
    field: np.ndarray,
    clean: np.ndarray,
    r: int,
    c: int,
    diagonal_cost: float,
    use_clean: bool,
) -> float:
    """A cost-to-go ``field`` (``kw`` with ``use_clean``, else ``k``) at (r, c); for a cell off
    the wave's grid (a sealed start, say), the best ``cost (+ clean) + field`` over its moves."""
    here = field[r, c] if passable[r, c] else np.inf
    static = _legal_moves(passable, r, c, 0)
    for i in range(8):
        if (static >> i) & 1:
            yr = r + DR[i]
            yc = c + DC[i]
            v = (diagonal_cost if i & 1 else 1.0) + field[yr, yc]
            if use_clean:
                v += clean[yr, yc]
            if v < here:
                here = v
    return here


@njit(cache=True, nogil=True)
def _decide_core(
    passable: np.ndarray,
    k: np.ndarray,
    kw: np.ndarray,
    clean: np.ndarray,
    r: int,
    c: int,
    dyn: int,
    raw: int,
    on_me: bool,
    contact: np.ndarray,
    tabu: int,
    goal_r: int,
    goal_c: int,
    mode: int,
    alpha: float,
    beta: float,
    diagonal_cost: float,
    target: int,
) -> tuple[int, int]:
    """(move index or -1, outcome) for the robot at (r, c).

    ``dyn``: neighbours blocked by dynamic obstacles this step, margin included (bit mask);
    ``raw``: neighbours an obstacle stands on; ``on_me``: an obstacle stands on the robot's cell;
    ``contact[i]``: obstacles touching neighbour i; ``tabu``: visited neighbours (bit mask, paper
    decision only); ``target``: the flat index of a detour's next cell, or -1.

    A detour's next cell is taken when no dynamic obstacle blocks the move (the detour itself
    is statically legal: it may cross cells the decision's grid seals). The paper decision
    waits when the neighbour it prefers with no dynamic obstacles is blocked (docs/algorithm.md);
    the wide one takes the best feasible neighbour that is closer, else waits.
    """
    W = passable.shape[1]
    chosen = -1
    if target >= 0:
        tr = target // W
        tc = target - tr * W
        for i in range(8):
            if r + DR[i] != tr or c + DC[i] != tc or (dyn >> i) & 1:
                continue
            # A diagonal squeezes past neither of its orthogonal cells when one is blocked.
            if not (i & 1) or not ((dyn >> ((i + 7) & 7)) & 1 or (dyn >> ((i + 1) & 7)) & 1):
                chosen = i
        if chosen >= 0:
            return chosen, MOVE
    else:
        here = _cost_here(passable, kw, clean, r, c, diagonal_cost, True)
        if here == np.inf:
            return -1, BLOCKED
        feasible = _legal_moves(passable, r, c, dyn)
        wide = True
        if mode == MODE_PAPER:
            static = _legal_moves(passable, r, c, 0)
            best = np.inf
            preferred = -1
            for i in range(8):
                if not ((static >> i) & 1) or (tabu >> i) & 1:
                    continue
                yr = r + DR[i]
                yc = c + DC[i]
                if k[yr, yc] == np.inf:
                    continue
                h = np.sqrt((yr - goal_r) ** 2.0 + (yc - goal_c) ** 2.0)
                # Eq. (3): P(Y) = S(Y) / sum(S); the least P is the least S.
                s = (k[yr, yc] + clean[yr, yc]) ** alpha * h**beta
                if s < best:
                    best = s
                    preferred = i
            if preferred >= 0:
                wide = False
                if (feasible >> preferred) & 1:
                    chosen = preferred
        if wide:
            # The wide decision: the feasible neighbour of least cost + clean + kw, if closer.
            best = np.inf
            for i in range(8):
                if (feasible >> i) & 1:
                    v = _wide_value(kw, clean, r, c, i, diagonal_cost)
                    if v < best:
                        best = v
                        chosen = i
            if chosen >= 0 and not kw[r + DR[chosen], c + DC[chosen]] < here:
                chosen = -1
        if chosen >= 0:
            return chosen, MOVE
    if on_me:
        # Move away, to the neighbour of least contact (then the best by the wide value); a cell
        # beside an obstacle beats staying on one, so only occupied cells are refused here.
        escape = _legal_moves(passable, r, c, raw)
        best_contact = 1 << 30
        best = np.inf
        for i in range(8):
            if not (escape >> i) & 1:
                continue
            v = _wide_value(kw, clean, r, c, i, diagonal_cost)
            if v == np.inf:
                continue
            if contact[i] < best_contact or (contact[i] == best_contact and v < best):
                best_contact = contact[i]
                best = v
                chosen = i
        if chosen >= 0:
            return chosen, EVADE
    return -1, WAIT


@njit(cache=True, nogil=True)
def _decide(
    passable: np.ndarray,
    k: np.ndarray,
    kw: np.ndarray,
    clean: np.ndarray,
    r: int,
    c: int,
    obstacles: np.ndarray,
    margin: int,
    tabu: int,
    goal_r: int,
    goal_c: int,
    mode: int,
    alpha: float,
    beta: float,
    diagonal_cost: float,
    target: int,
) -> tuple[int, int]:
    """One step's decision among dynamic ``obstacles`` (an (m, 2) array of cells), each blocking
    the cells within Chebyshev distance ``margin`` of it."""
    dyn = 0
    raw = 0
    on_me = False
    contact = np.zeros(8, dtype=np.int64)
    reach = max(margin, 1) + 1
    for j in range(obstacles.shape[0]):
        dr = obstacles[j, 0] - r
        dc = obstacles[j, 1] - c
        if abs(dr) > reach or abs(dc) > reach:
            continue
        if dr == 0 and dc == 0:
            on_me = True
        for i in range(8):
            d = max(abs(dr - DR[i]), abs(dc - DC[i]))
            if d == 0:
                raw |= 1 << i
            elif d == 1:
                contact[i] += 1
            if d <= margin:
                dyn |= 1 << i
    return _decide_core(
        passable, k, kw, clean, r, c, dyn, raw, on_me, contact, tabu, goal_r, goal_c, mode,
        alpha, beta, diagonal_cost, target,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def _walk(
    passable: np.ndarray,
    k: np.ndarray,
    kw: np.ndarray,
    clean: np.ndarray,
    start: int,
    goal: int,
    mode: int,
    alpha: float,
    beta: float,
    diagonal_cost: float,
    max_steps: int,
) -> np.ndarray:
    """The path (flat indices, start first) the decision follows with no dynamic obstacles.

    Returns an empty array when the goal is not reached within ``max_steps`` moves.
    """
    H, W = passable.shape
    # Only the paper decision keeps a tabu list; the wide one never revisits a cell.
    visited = np.zeros(H * W if mode == MODE_PAPER else 1, dtype=np.uint8)
    path = np.empty(min(max_steps + 1, 1024), dtype=np.int64)
    contact = np.zeros(8, dtype=np.int64)
    gr = goal // W
    gc = goal - gr * W
    x = start
    path[0] = x
    if mode == MODE_PAPER:
        visited[x] = 1
    n = 1
    while x != goal:
        if n > max_steps:
            return path[:0].copy()
        if n == path.shape[0]:
            grown = np.empty(min(2 * n, max_steps + 1), dtype=np.int64)
            grown[:n] = path
            path = grown
        r = x // W
        c = x - r * W
        tabu = 0
        if mode == MODE_PAPER:
            for i in range(8):
                yr = r + DR[i]
                yc = c + DC[i]
                if 0 <= yr < H and 0 <= yc < W and visited[yr * W + yc]:
                    tabu |= 1 << i
        i, outcome = _decide_core(
            passable, k, kw, clean, r, c, 0, 0, False, contact, tabu, gr, gc, mode, alpha, beta,
            diagonal_cost, -1,
        )  # fmt: skip
        if outcome != MOVE:
            return path[:0].copy()
        x = (r + DR[i]) * W + c + DC[i]
        if mode == MODE_PAPER:
            visited[x] = 1
        path[n] = x
        n += 1
    return path[:n].copy()


@njit(cache=True, nogil=True)
def _detour(
    passable: np.ndarray,
    field: np.ndarray,
    clean: np.ndarray,
    start: int,
    goal: int,
    diagonal_cost: float,
    obstacles: np.ndarray,
    margin: int,
    use_field: bool,
) -> np.ndarray:
    """The replan of §4: A* from ``start`` to ``goal`` over ``passable`` with every cell within
    Chebyshev distance ``margin`` of a dynamic obstacle blocked.

    Costs are the wide ones (move + clean of the cell entered). With ``use_field`` the heuristic
    is ``field`` (``kw``: the exact cost-to-go over ``passable`` without dynamic obstacles, so the
    search stays near the blocked stretch, and cells it marks unreachable are skipped); else the
    octile distance, for a grid the field was not computed on (the unsealed one). Both are
    consistent, so the detour is optimal. Returns the cells after ``start`` up to the goal (flat
    indices), or an empty array when there is no way. ``start`` itself may be blocked.
    """
    H, W = passable.shape
    n = H * W
    free = passable.ravel().copy()
    for j in range(obstacles.shape[0]):
        orow = obstacles[j, 0]
        ocol = obstacles[j, 1]
        for r in range(max(orow - margin, 0), min(orow + margin + 1, H)):
            for c in range(max(ocol - margin, 0), min(ocol + margin + 1, W)):
                free[r * W + c] = 0
    if free[goal] == 0:
        return np.empty(0, dtype=np.int64)
    gr = goal // W
    gc = goal - gr * W
    straight = min(diagonal_cost, 2.0) - 1.0
    h = field.ravel()
    pen = clean.ravel()
    g = np.full(n, np.inf)
    parent = np.full(n, -1, dtype=np.int64)
    keys = np.empty(n, dtype=np.float64)
    items = np.empty(n, dtype=np.int64)
    pos = np.full(n, _OUTSIDE, dtype=np.int64)
    g[start] = 0.0
    size = _push_or_decrease(keys, items, pos, 0, start, 0.0)
    found = False
    while size > 0:
        x, _, size = _pop(keys, items, pos, size)
        if x == goal:
            found = True
            break
        xr = x // W
        xc = x - xr * W
        for i in range(8):
            yr = xr + DR[i]
            yc = xc + DC[i]
            if yr < 0 or yr >= H or yc < 0 or yc >= W:
                continue
            y = yr * W + yc
            if free[y] == 0 or pos[y] == _CLOSED:
                continue
            if use_field:
                hy = h[y]
                if hy == np.inf:
                    continue
            else:
                a = abs(yr - gr)
                b = abs(yc - gc)
                hy = max(a, b) + straight * min(a, b)
            if i & 1:
                if free[xr * W + yc] == 0 or free[yr * W + xc] == 0:
                    continue
                ng = g[x] + diagonal_cost + pen[y]
            else:
                ng = g[x] + 1.0 + pen[y]
            if ng < g[y]:
                g[y] = ng
                parent[y] = x
                size = _push_or_decrease(keys, items, pos, size, y, ng + hy)
    if not found:
        return np.empty(0, dtype=np.int64)
    count = 0
    x = goal
    while x != start:
        count += 1
        x = parent[x]
    out = np.empty(count, dtype=np.int64)
    x = goal
    for j in range(count - 1, -1, -1):
        out[j] = x
        x = parent[x]
    return out


# --------------------------------------------------------------------------------------------
# The paper's simulated dynamic obstacles (docs/algorithm.md).


@njit(cache=True, nogil=True)
def _move_obstacles(
    grid: np.ndarray,
    occupied: np.ndarray,
    obstacles: np.ndarray,
    robot_r: int,
    robot_c: int,
    u: np.ndarray,
) -> None:
    """Move each obstacle in place to a uniformly drawn option among staying and its legal moves
    (free static cell, no corner cutting, not another obstacle's cell, not the robot's cell).

    ``occupied`` counts obstacles per cell and is kept up to date; ``u`` holds one uniform
    [0, 1) number per obstacle, drawn by the caller's seeded generator.
    """
    H, W = grid.shape
    m = obstacles.shape[0]
    options = np.empty(9, dtype=np.int64)
    for j in range(m):
        r = obstacles[j, 0]
        c = obstacles[j, 1]
        count = 1
        options[0] = -1
        for i in range(8):
            yr = r + DR[i]
            yc = c + DC[i]
            if yr < 0 or yr >= H or yc < 0 or yc >= W or grid[yr, yc] != 0:
                continue
            if i & 1 and (grid[r, yc] != 0 or grid[yr, c] != 0):
                continue
            if (yr == robot_r and yc == robot_c) or occupied[yr, yc]:
                continue
            options[count] = i
            count += 1
        pick = options[min(int(u[j] * count), count - 1)]
        if pick >= 0:
            occupied[r, c] -= 1
            obstacles[j, 0] = r + DR[pick]
            obstacles[j, 1] = c + DC[pick]
            occupied[r + DR[pick], c + DC[pick]] += 1

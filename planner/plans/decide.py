"""Deciding the next move (docs/algorithm.md, "Deciding the next move" and "Dynamic obstacles"):
the paper's Eq. (3) and the loop-free ``wide``
decision, among dynamic obstacles, waiting, evading, and following a detour's next cell."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.params import Params
from planner.plans.moves import DC, DR
from planner.plans.whole_wave import WaveView

__all__ = [
    "BLOCKED",
    "EVADE",
    "MODE_PAPER",
    "MODE_WIDE",
    "MOVE",
    "WAIT",
    "Rule",
    "cost_here",
    "decide",
    "decide_core",
    "legal_moves",
]

# Decision outcomes.
MOVE = 0
EVADE = 1  # an obstacle entered the robot's cell: step aside, even if not closer
WAIT = 2
BLOCKED = 3  # the goal cannot be reached from here, whatever the dynamic obstacles do

MODE_WIDE = 0
MODE_PAPER = 1

_NO_OBSTACLES = np.empty((0, 2), dtype=np.int64)


class Rule(NamedTuple):
    """The decision's parameters, as the kernels take them."""

    mode: int
    alpha: float
    beta: float
    diagonal_cost: float

    @classmethod
    def of(cls, params: Params, *, wide: bool = False) -> Rule:
        """The rule of ``params`` (with ``wide``, the wide decision whatever they say)."""
        paper = params.decision == "paper" and not wide
        mode = MODE_PAPER if paper else MODE_WIDE
        return cls(mode, float(params.alpha), float(params.beta), float(params.diagonal_cost))


@njit(cache=True, nogil=True)
def legal_moves(passable: np.ndarray, r: int, c: int, dyn: int) -> int:
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
    static = legal_moves(passable, r, c, 0)
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


def cost_here(
    view: WaveView, cell: tuple[int, int], *, diagonal_cost: float, use_clean: bool
) -> float:
    """``kw`` (with ``use_clean``, else ``k``) at ``cell`` (of the map) from a wave's ``view``;
    off the wave's grid, the best ``cost (+ clean) + field`` over its moves (see ``_cost_here``).
    """
    r, c = cell[0] - view.top, cell[1] - view.left
    if not (0 <= r < view.passable.shape[0] and 0 <= c < view.passable.shape[1]):
        raise ValueError(f"cell {cell!r} is outside the view given.")
    field = view.kw if use_clean else view.k
    return float(_cost_here(view.passable, field, view.clean, r, c, diagonal_cost, use_clean))


@njit(cache=True, nogil=True)
def decide_core(
    fields: tuple[Any, ...],
    r: int,
    c: int,
    dyn: int,
    raw: int,
    on_me: bool,
    contact: np.ndarray,
    tabu: int,
    goal: tuple[int, int],
    rule: tuple[int, float, float, float],
    target: int,
) -> tuple[int, int]:
    """(move index or -1, outcome) for the robot at (r, c).

    ``fields``: the window's grid, ``k``, ``kw`` and ``clean`` (a :class:`WaveView` or a
    tuple); ``rule``: a :class:`Rule`; ``dyn``: neighbours blocked by dynamic obstacles this
    step, margin included (bit mask);
    ``raw``: neighbours an obstacle stands on; ``on_me``: an obstacle stands on the robot's cell;
    ``contact[i]``: obstacles touching neighbour i; ``tabu``: visited neighbours (bit mask, paper
    decision only); ``target``: the flat index of a detour's next cell, or -1.

    A detour's next cell is taken when no dynamic obstacle blocks the move (the detour itself
    is statically legal: it may cross cells the decision's grid seals). The paper decision
    waits when the neighbour it prefers with no dynamic obstacles is blocked (docs/algorithm.md,
    "Dynamic obstacles and stepping");
    the wide one takes the best feasible neighbour that is closer, else waits.
    """
    passable, k, kw, clean = fields[0], fields[1], fields[2], fields[3]
    goal_r, goal_c = goal
    mode, alpha, beta, diagonal_cost = rule[0], rule[1], rule[2], rule[3]
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
        feasible = legal_moves(passable, r, c, dyn)
        wide = True
        if mode == MODE_PAPER:
            static = legal_moves(passable, r, c, 0)
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
        escape = legal_moves(passable, r, c, raw)
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
    the cells within Chebyshev distance ``margin`` of it (arrays and scalars: a step calls it
    from Python, where tuples cost more to pass)."""
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
    fields = (passable, k, kw, clean)
    rule = (mode, alpha, beta, diagonal_cost)
    return decide_core(fields, r, c, dyn, raw, on_me, contact, tabu, (goal_r, goal_c), rule, target)


def decide(
    view: WaveView,
    cell: tuple[int, int],
    rule: Rule,
    obstacles: npt.NDArray[np.int64] = _NO_OBSTACLES,
    *,
    goal: tuple[int, int],
    margin: int = 0,
    tabu: int = 0,
    target: tuple[int, int] | None = None,
) -> tuple[int, int]:
    """(move index or -1, outcome) of one step at ``cell`` (of the map) over what a wave's
    ``view`` holds, among dynamic ``obstacles`` (``(m, 2)`` cells of the map) each blocking the
    cells within ``margin``; ``tabu``: the visited neighbours (bit mask); ``target``: a detour's
    next cell, if any; ``goal``: the wave's goal."""
    r, c = cell[0] - view.top, cell[1] - view.left
    h, w = view.passable.shape
    if not (0 <= r < h and 0 <= c < w):
        msg = f"cell {cell!r} is outside the {h} x {w} view at ({view.top}, {view.left}) given."
        raise ValueError(msg)
    if view.top or view.left:  # a window of the map: its cells are relative to it
        obstacles = obstacles - np.array([view.top, view.left], dtype=np.int64)
    local = -1
    if target is not None:
        tr, tc = target[0] - view.top, target[1] - view.left
        local = tr * w + tc if 0 <= tr < h and 0 <= tc < w else h * w  # outside: never taken
    i, outcome = _decide(
        view.passable, view.k, view.kw, view.clean, r, c, obstacles, margin, tabu,
        goal[0] - view.top, goal[1] - view.left, rule.mode, rule.alpha, rule.beta,
        rule.diagonal_cost, local,
    )  # fmt: skip
    return int(i), int(outcome)

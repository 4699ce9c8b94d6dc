"""LaCAM (Okumura, AAAI 2023) and its anytime refinement LaCAM* (IJCAI 2023): a complete
depth-first search over configurations. Each configuration (high-level node) carries a lazy tree
of low-level constraints (which agents go where next), unfolded one constraint per visit; PIBT
makes the successor that meets a constraint. Every successor is reachable through the tree, so
the search finds a solution whenever one exists, and proves there is none by exhausting it."""

from __future__ import annotations

import random
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from planner.fleets.pibt import Pibt

__all__ = ["Search", "Status", "lacam"]

Status = Literal["solved", "timeout", "unsolvable"]

_Constraint = tuple[tuple[int, ...], tuple[int, ...]]
"""A low-level node: the agents whose next node is fixed (in the configuration's order), and
those nodes."""


class _Configuration:
    """A high-level node: a configuration, how it was reached (``parent``, cost ``g`` from the
    start), its agents' PIBT priorities and order, and its constraint tree still to unfold."""

    __slots__ = ("config", "g", "h", "neighbours", "order", "parent", "priority", "tree")

    def __init__(
        self,
        config: npt.NDArray[np.int64],
        parent: _Configuration | None,
        priority: npt.NDArray[np.float64],
        g: int,
        h: int,
    ) -> None:
        self.config = config
        self.parent = parent
        self.priority = priority
        self.order = np.argsort(-priority, kind="stable").astype(np.int64)
        self.tree: deque[_Constraint] = deque([((), ())])
        self.g = g
        self.h = h
        self.neighbours: set[_Configuration] = set()


@dataclass(frozen=True, slots=True)
class Search:
    """What a search found: ``configs`` from the starts to the goals (empty unless solved), how
    many constraints it tried (``expanded``, one PIBT call each) and configurations it met."""

    status: Status
    configs: list[npt.NDArray[np.int64]]
    expanded: int
    configurations: int


def lacam(
    pibt: Pibt,
    neighbours: list[list[int]],
    starts: npt.NDArray[np.int64],
    goals: npt.NDArray[np.int64],
    steps: npt.NDArray[np.int64],
    *,
    deadline: float,
    seed: int = 0,
    refine: bool = False,
) -> Search:
    """Search from ``starts`` to ``goals`` (node per agent, checked by the caller) until solved
    (or, with ``refine``, until the sum of costs is proven least or ``deadline`` comes), the
    space is exhausted (``unsolvable``) or ``time.perf_counter()`` passes ``deadline``.

    ``neighbours[v]`` lists node ``v``'s neighbours; ``steps`` (``(k, n)``) the agents' step
    distances to their goals, every start's finite.
    """
    k = len(starts)
    agents = np.arange(k)
    tie = random.Random(seed)
    free = np.full(k, -1, dtype=np.int64)
    goal_key = goals.tobytes()

    def cost(a: npt.NDArray[np.int64], b: npt.NDArray[np.int64]) -> int:
        # Every agent that is not staying at its goal pays one step.
        return k - int(np.count_nonzero((a == goals) & (b == goals)))

    first = np.ascontiguousarray(starts, dtype=np.int64)
    priority = steps[agents, first] / max(steps.shape[1], 1)
    root = _Configuration(first, None, priority, 0, int(steps[agents, first].sum()))
    explored: dict[bytes, _Configuration] = {first.tobytes(): root}
    stack = [root]
    goal: _Configuration | None = root if first.tobytes() == goal_key else None
    expanded = 0
    while stack and (goal is None or refine):
        if time.perf_counter() > deadline:
            break
        node = stack[-1]
        if goal is not None and goal.g <= node.g + node.h:
            stack.pop()
            continue
        if not node.tree:
            stack.pop()
            continue
        who, where = node.tree.popleft()
        if len(who) < k:
            i = int(node.order[len(who)])
            v = int(node.config[i])
            nexts = [*neighbours[v], v]
            tie.shuffle(nexts)
            node.tree.extend(((*who, i), (*where, u)) for u in nexts)
        fixed = free
        if who:
            fixed = free.copy()
            fixed[list(who)] = where
        expanded += 1
        config = pibt.step(node.config, node.order, fixed, tie.getrandbits(62))
        if config is None:
            continue
        key = config.tobytes()
        known = explored.get(key)
        if known is None:
            at_goal = config == goals
            priority = np.where(at_goal, node.priority - np.floor(node.priority), node.priority + 1)
            h = int(steps[agents, config].sum())
            known = _Configuration(config, node, priority, node.g + cost(node.config, config), h)
            explored[key] = known
            if goal is None and key == goal_key:
                goal = known
        if refine:
            node.neighbours.add(known)
            if known.parent is not node:
                _rewrite(node, cost, goal, stack)
        stack.append(known)  # a known configuration on top again: it often leads out
    if goal is not None:
        configs = []
        at: _Configuration | None = goal
        while at is not None:
            configs.append(at.config)
            at = at.parent
        return Search("solved", configs[::-1], expanded, len(explored))
    status: Status = "unsolvable" if not stack else "timeout"
    return Search(status, [], expanded, len(explored))


def _rewrite(
    start: _Configuration,
    cost: Callable[[npt.NDArray[np.int64], npt.NDArray[np.int64]], int],
    goal: _Configuration | None,
    stack: list[_Configuration],
) -> None:
    """LaCAM*'s update when a known configuration is met again: costs from ``start`` spread
    through the configurations met from it (Dijkstra-like), parents following the cheaper way;
    those that could now beat the goal's cost go back on the stack."""
    queue = deque([start])
    while queue:
        at = queue.popleft()
        for to in at.neighbours:
            g = at.g + cost(at.config, to.config)
            if g < to.g:
                to.g, to.parent = g, at
                queue.append(to)
                if goal is not None and to.g + to.h < goal.g:
                    stack.append(to)

"""Pockets: cells cut off from a goal. A small search from a robot's cell that runs out of cells
before it reaches the goal proves the robot cut off at the cost of the pocket, not of the
goal's search through its whole region; the last pockets found are kept (a robot in one asks
again at every step)."""

from __future__ import annotations

import numpy as np

from planner.analysis.analyse import Analysis
from planner.plans.search import GoalSearch

__all__ = ["Pockets"]

PROBE_CELLS = 4096
"""The most cells a probe settles: most pockets are found at once."""
KEPT = 4
"""How many pockets are kept."""


class Pockets:
    """The pockets found round one goal's grid (``open_``: see ``moves``).

    >>> from planner import analyse
    >>> from planner.plans.moves import OPEN_UNSEALED
    >>> grid = [[0, 1, 0, 0, 0], [1, 1, 0, 0, 0], [0, 0, 0, 0, 0]]  # (0, 0) walled off
    >>> a = analyse(grid, seal_tunnels=False, clean_weight=0)
    >>> pockets = Pockets(a, (2, 4), open_=OPEN_UNSEALED, diagonal_cost=1.5)
    >>> pockets.probe(0), pockets.holds(0), pockets.probe(10)
    (True, True, False)
    """

    def __init__(
        self, analysis: Analysis, goal: tuple[int, int], *, open_: int, diagonal_cost: float
    ) -> None:
        self.analysis = analysis
        self.goal = goal
        self.open = open_
        self.diagonal_cost = diagonal_cost
        self._found: list[GoalSearch] = []

    def holds(self, cell: int) -> bool:
        """Whether a pocket found already holds ``cell`` (a flat index)."""
        return any(pocket.seen(cell) for pocket in self._found)

    def probe(self, cell: int) -> bool:
        """Whether a search from ``cell`` (a flat index) runs out of cells within
        :data:`PROBE_CELLS` before it reaches the goal: then its pocket is kept."""
        flat_goal = self.goal[0] * self.analysis.shape[1] + self.goal[1]
        search = GoalSearch(
            self.analysis, flat_goal, open_=self.open, use_clean=False,
            diagonal_cost=self.diagonal_cost, root=cell,
        )  # fmt: skip
        search.settle(np.array([flat_goal], dtype=np.int64), self.goal, 0.0, PROBE_CELLS)
        if search.exhausted:
            self._found = [search, *self._found[: KEPT - 1]]
        return search.exhausted

    def clear(self) -> None:
        self._found = []

    @property
    def nbytes(self) -> int:
        return sum(pocket.nbytes for pocket in self._found)

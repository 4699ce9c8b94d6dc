"""A path's figures: its length and arc cost, its clearances."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.params import SQRT2
from planner.plans.whole_wave import Wave

__all__ = ["clearance_metrics", "path_cost"]


def path_cost(path: npt.NDArray[np.int64], wave: Wave) -> tuple[float, float]:
    """(length, arc cost) of a path of cells. The length counts a diagonal sqrt 2 cells (one
    rule for every length the planner reports); the arc cost is the paper's ``PathCost``: the
    sum of ``k`` over the cells entered after the start."""
    steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
    length = float(np.count_nonzero(steps == 1) + np.count_nonzero(steps == 2) * SQRT2)
    return length, float(wave.k_along(path[1:]).sum())


def clearance_metrics(
    path: npt.NDArray[np.int64], analysis: Analysis
) -> tuple[float, float, float]:
    """(min clearance, mean clearance, contact ratio) of a path of cells: distances to the
    nearest static obstacle, and the share of cells below 1.5 (touching one, diagonally too)."""
    clearance = analysis.clearance[path[:, 0], path[:, 1]].astype(np.float64)
    contact = float(np.count_nonzero(clearance < 1.5)) / len(path)
    return float(clearance.min()), float(clearance.mean()), contact

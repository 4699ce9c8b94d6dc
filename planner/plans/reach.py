"""Whether a goal's wave reaches a start, and the route down it: the wave a plan takes (the
sealed grid's, else the narrow one's when allowed) and the cells the decision visits."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.errors import InvalidInput, NoValidPath
from planner.maps.grids import as_cell
from planner.plans.decide import Rule, cost_here
from planner.plans.resumable_wave import ResumableWave
from planner.plans.walk import walk_fields
from planner.plans.whole_wave import Wave

__all__ = ["reaches", "route", "wave_to"]


def wave_to(
    analysis: Analysis,
    s: tuple[int, int],
    g: tuple[int, int],
    allow_narrow: bool,
    wave_for: Callable[[tuple[int, int], bool], Wave],
) -> tuple[Wave, bool]:
    """The goal wave of ``g`` that reaches ``s`` (the sealed grid's, else the narrow one's when
    allowed), and whether it is the narrow one; else NoValidPath."""
    wave = wave_for(g, False)
    narrow = False
    if not reaches(wave, analysis, s) and analysis.sealed:
        narrow_wave = wave_for(g, True)
        if reaches(narrow_wave, analysis, s):
            if not allow_narrow:
                msg = (
                    f"goal {list(g)} can be reached from start {list(s)} only through tight "
                    "tunnels, and allow_narrow is false"
                )
                raise NoValidPath(msg, field="goal")
            wave, narrow = narrow_wave, True
    if not reaches(wave, analysis, s):
        raise NoValidPath(f"goal {list(g)} cannot be reached from start {list(s)}", field="goal")
    return wave, narrow


def reaches(wave: Wave, analysis: Analysis, cell: Any) -> bool:
    """Whether the robot at ``cell`` (``[row, col]``) can reach the wave's goal over the
    wave's grid.

    >>> from planner import analyse, goal_wave
    >>> a = analyse([[0, 1], [1, 0]], seal_tunnels=False)
    >>> reaches(goal_wave(a, [0, 0]), a, [1, 1])
    False
    >>> reaches(goal_wave(a, [0, 0]), a, [-1, 0])
    Traceback (most recent call last):
    ...
    planner.errors.InvalidInput: cell [-1, 0] is outside the 2 x 2 map
    """
    r, c = as_cell(cell, analysis.shape, name="cell")
    if wave.shape != analysis.shape:
        msg = f"the wave's map is {wave.shape}, the analysis's {analysis.shape}"
        raise InvalidInput(msg, field="wave")
    v = wave.view(r, c, analysis.clean)
    here = cost_here(v, (r, c), diagonal_cost=wave.diagonal_cost, use_clean=True)
    return bool(np.isfinite(here))


def route(
    wave: Wave,
    analysis: Analysis,
    start: tuple[int, int],
    goal: tuple[int, int],
    rule: Rule,
) -> npt.NDArray[np.int64]:
    """The cells (flat) the decision of ``rule`` visits from ``start`` with no dynamic
    obstacles, down ``wave``'s fields (a resumable wave settling what it reads); empty when it
    does not reach ``goal``."""
    H, W = analysis.shape
    if isinstance(wave, ResumableWave):
        return wave.walk(start, rule, 4 * H * W + 8)
    view = wave.view(start[0], start[1], analysis.clean)
    flat_goal = goal[0] * W + goal[1]
    return walk_fields(view, start[0] * W + start[1], flat_goal, rule, max_steps=4 * H * W + 8)

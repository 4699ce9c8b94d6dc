"""Bounded detours (``params.max_detour``): the ``wide`` route is never longer than
``max_detour`` times the shortest route on the same configuration space. Width goes first: the
wall term is scaled down until the route is within the bound (the widest of ``1/2, 1/4, ...,
1/16``, then none: the shortest route on the sealed grid, found by bisection in three trials at
most), and as a last resort the tunnels sealing shut are opened (the shortest route itself).
The wall term is linear in its weight and the shares are powers of two, so the analysis made
with the weights given up is the scaled one to the bit: a plan rebuilt from its effective
``params`` follows the same route."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np

from planner.analysis.analyse import Analysis, params_key
from planner.params import Params
from planner.plans.resumable_wave import ResumableWave, resumable_wave
from planner.plans.whole_wave import Wave, goal_wave

__all__ = ["SCALES", "Detour", "bound_detour", "bound_route"]

#: The shares of the wall term tried, in order, until the route is within the bound.
SCALES = (0.5, 0.25, 0.125, 0.0625, 0.0)

#: Relative slack on the bound (float sums along a path).
_SLACK = 1e-9


class Bounded(Protocol):
    """What a bound reads of a plan: a :class:`~planner.Plan` (this module does not import it:
    ``planning`` imports this one)."""

    @property
    def params(self) -> Params: ...
    @property
    def analysis(self) -> Analysis: ...
    @property
    def goal(self) -> tuple[int, int]: ...
    @property
    def narrow_fallback(self) -> bool: ...
    @property
    def wave(self) -> Wave: ...
    @property
    def length(self) -> float: ...
    @property
    def elapsed_ms(self) -> float: ...


Plan = TypeVar("Plan", bound=Bounded)


@dataclass(frozen=True)
class Detour:
    """How a ``wide`` route compares with the shortest: ``shortest`` (cells, diagonals sqrt 2)
    on the same configuration space, tunnels open; ``width_kept`` the share of the wall term
    (``clean_weight`` / ``wide_weight``) the route was planned with, 1 when nothing was given
    up, 0 for the shortest route on the sealed grid; ``tunnels_opened`` when even that was
    longer than the bound and the route is the shortest one, through tunnels."""

    shortest: float
    width_kept: float = 1.0
    tunnels_opened: bool = False


def bound_detour(result: Plan, *, whole: bool = False, t0: float | None = None) -> Plan:
    """``result`` (a ``wide`` plan) within ``max_detour`` times the shortest route, with its
    :class:`Detour`; width given up as little as :data:`SCALES` allow. New waves are whole-map
    ones with ``whole``, else resumable; ``t0`` (``perf_counter``) restarts the plan's time."""
    p = result.params
    shortest_plan = _scaled(result, 0.0, narrow=True, whole=whole)
    shortest = shortest_plan.length
    bound = p.max_detour * shortest * (1 + _SLACK)
    chosen, detour = result, Detour(shortest)
    if shortest > 0 and result.length > bound:
        chosen, detour = shortest_plan, Detour(shortest, width_kept=0.0, tunnels_opened=True)
        # The widest share within the bound, by bisection (a route gets no longer as the wall
        # term shrinks; were it to, a share within the bound is still taken, a narrower one).
        low, high = 0, len(SCALES)
        while low < high:
            middle = (low + high) // 2
            trial = _scaled(result, SCALES[middle], narrow=result.narrow_fallback, whole=whole)
            if trial.length <= bound:
                chosen, detour = trial, Detour(shortest, width_kept=SCALES[middle])
                high = middle
            else:
                low = middle + 1
    elapsed = chosen.elapsed_ms if t0 is None else (time.perf_counter() - t0) * 1e3
    return _keeping_path(chosen, detour=detour, elapsed_ms=elapsed)


def bound_route(
    legs: Sequence[Plan],
    join: Callable[[list[Plan]], Plan],
    *,
    whole: bool = False,
    t0: float | None = None,
) -> Plan:
    """A route through waypoints (its ``legs``, joined by ``join``) within ``max_detour`` times
    the shortest route through the same waypoints (the sum of each leg's shortest), with its
    :class:`Detour`. One share of the wall term holds for every leg, the widest within the bound
    on the whole route (a leg may then be longer than the bound on its own, another shorter),
    so that the route keeps one set of effective ``params``; the last resort opens every leg's
    tunnels. The legs share their map's analysis, so each share's is made once; each shortest
    leg is measured and let go (a route may have 65 legs)."""
    p, analysis = legs[0].params, legs[0].analysis
    made: dict[float, tuple[Params, Analysis]] = {}

    def again(leg: Plan, share: float, narrow: bool) -> Plan:
        if share not in made:  # one analysis a share, for every leg
            params = _scaled_params(p, share)
            made[share] = params, scaled_analysis(analysis, params, share)
        return _scaled(leg, share, narrow=narrow, whole=whole, made=made[share])

    shortest = sum(again(leg, 0.0, True).length for leg in legs)
    bound = p.max_detour * shortest * (1 + _SLACK)
    chosen, detour = list(legs), Detour(shortest)
    if shortest > 0 and sum(leg.length for leg in legs) > bound:
        chosen, detour = [], Detour(shortest, width_kept=0.0, tunnels_opened=True)
        low, high = 0, len(SCALES)
        while low < high:  # as bound_detour's bisection, the share the same on every leg
            middle = (low + high) // 2
            share = SCALES[middle]
            trial = [again(leg, share, leg.narrow_fallback) for leg in legs]
            if sum(leg.length for leg in trial) <= bound:
                chosen, detour = trial, Detour(shortest, width_kept=share)
                high = middle
            else:
                low = middle + 1
        if not chosen:  # even the sealed grid's shortest is over: every leg's tunnels open
            chosen = [again(leg, 0.0, True) for leg in legs]
    route = join(chosen)
    elapsed = route.elapsed_ms if t0 is None else (time.perf_counter() - t0) * 1e3
    return _keeping_path(route, detour=detour, elapsed_ms=elapsed)


def _keeping_path(plan: Plan, **changes: Any) -> Plan:
    """``plan`` with ``changes`` to fields its path does not depend on, its path kept."""
    out: Plan = dataclasses.replace(plan, **changes)  # type: ignore[type-var]
    vars(out).update({k: v for k, v in vars(plan).items() if k in ("path", "_cost")})
    return out


def _scaled_params(p: Params, scale: float) -> Params:
    return dataclasses.replace(
        p, clean_weight=p.clean_weight * scale, wide_weight=p.wide_weight * scale
    )


def _scaled(
    result: Plan,
    scale: float,
    *,
    narrow: bool,
    whole: bool,
    made: tuple[Params, Analysis] | None = None,
) -> Plan:
    """``result`` planned again with its wall term's weights times ``scale`` (``narrow``: over
    the unsealed grid); ``made``: those params and their analysis, made already."""
    p = result.params
    if made is None:
        params = _scaled_params(p, scale)
        made = params, scaled_analysis(result.analysis, params, scale)
    params, analysis = made
    wave = _plain_wave(result, narrow) if scale == 0 else None
    if wave is None:
        # A goal whose search handed over to the whole-map wave is far for these too: theirs
        # at once.
        far = whole or not isinstance(result.wave, ResumableWave) or not result.wave.resumable
        new = goal_wave if far else resumable_wave
        wave = new(analysis, result.goal, diagonal_cost=p.diagonal_cost, narrow=narrow)
    out: Plan = dataclasses.replace(  # type: ignore[type-var]
        result,
        params=params,
        analysis=analysis,
        wave=wave,
        narrow_fallback=narrow or result.narrow_fallback,
    )
    return out


def _plain_wave(result: Plan, narrow: bool) -> Wave | None:
    """The goal wave without the wall term over the grid asked for (``narrow``: the unsealed
    one), when ``result``'s whole-map wave already holds it: its ``k`` is that wave, to the bit
    (the same grid, goal and moves), so none is computed again (a far goal's on a 4096 x 4096
    map: 168 MB and 0.7 s). None when the wave is still a search or on another grid."""
    wave = result.wave
    whole = wave.handed_over if isinstance(wave, ResumableWave) else wave
    if whole is None or (whole.narrow != narrow and result.analysis.sealed):
        return None
    return Wave(
        whole.goal, whole.k, whole.k, whole.passable,
        narrow=narrow, diagonal_cost=whole.diagonal_cost, elapsed_ms=0.0,
    )  # fmt: skip


def scaled_analysis(analysis: Analysis, params: Params, scale: float) -> Analysis:
    """``analysis`` with its wall term times ``scale``: the analysis of ``params`` (whose
    weights are the analysis's times ``scale``, a power of two or 0)."""
    if scale == 0:  # zeros the process maps only if they are written: no memory for the term
        clean = np.zeros(analysis.clean.shape, dtype=np.float32)
    else:
        clean = analysis.clean * np.float32(scale)
    return dataclasses.replace(
        analysis,
        clean=clean,
        clean_weight=analysis.clean_weight * scale,
        params_key=params_key(params, plain=analysis.plain),
    )

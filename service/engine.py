"""What every resource shares: the store, the analysis cache, the worker pool, and plans built
from cached analyses and goal waves.

The resource modules (``maps``, ``plans``, ``simulation``) do their work through an
:class:`Engine`. A plan is built once, in the pool (:meth:`Engine.build_plan`); its record keeps
the resolved parameters and whether it took the narrow fallback, so a step finds the plan's
analysis and wave again by key (:meth:`Engine.plan_of`) without resolving or rebuilding anything.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass
from typing import Any

import planner
from planner._errors import quote
from schemas import PlanCreate, SimulationCreate
from service.cache import ByteLRU
from service.config import Settings
from service.errors import NotFound, TooLarge
from service.pool import Pool
from service.stores import Grid, PlanRecord, Store
from service.tenants import scoped

__all__ = [
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE",
    "Engine",
    "analysis_key",
    "cell_size",
    "overrides",
    "wave_key",
]

MAX_IMAGE_SIDE = 8192
"""Pixels on a picture's longer side at most: a 4096 x 4096 map at 2 pixels a cell."""
MAX_IMAGE_PIXELS = 4096 * 4096
"""Pixels of a picture at most (a few seconds to draw and compress, ~50 MB while drawn)."""


def analysis_key(map_id: str, params: planner.Params) -> Hashable:
    """The cache key of a map's analysis for ``params`` (the tenant's: see ``tenants``)."""
    return ("analysis", scoped(map_id), *params.analysis_key)


def wave_key(map_id: str, params: planner.Params, goal: Any, narrow: bool) -> Hashable:
    """The cache key of a goal wave over that analysis (``narrow``: over the unsealed grid)."""
    key = ("wave", scoped(map_id), *params.analysis_key, tuple(goal), params.diagonal_cost)
    return (*key, narrow)


def overrides(body: PlanCreate | SimulationCreate) -> dict[str, Any]:
    """The planner parameters a request overrides: ``params``, with ``allow_narrow`` on top."""
    if body.allow_narrow is None:
        return dict(body.params)
    return {**body.params, "allow_narrow": body.allow_narrow}


def cell_size(shape: tuple[int, int], cell: int | None) -> int:
    """Pixels per cell of a picture: the caller's, within the image limit, or one that makes a
    picture of about 800 pixels (1 to 10 a cell)."""
    side = max(shape)
    if cell is None:
        return max(1, min(10, 800 // side))
    if side * cell > MAX_IMAGE_SIDE:
        msg = (
            f"cell {cell} would draw the {shape[0]} x {shape[1]} map {side * cell} pixels wide; "
            f"the limit is {MAX_IMAGE_SIDE} (use cell <= {max(1, MAX_IMAGE_SIDE // side)})"
        )
        raise planner.InvalidInput(msg, field="cell")
    pixels = shape[0] * shape[1] * cell * cell
    if pixels > MAX_IMAGE_PIXELS:
        fits = max(1, math.isqrt(MAX_IMAGE_PIXELS // (shape[0] * shape[1])))
        msg = (
            f"cell {cell} would draw the {shape[0]} x {shape[1]} map in {pixels} pixels; the "
            f"limit is {MAX_IMAGE_PIXELS} (use cell <= {fits})"
        )
        raise TooLarge(msg, field="cell")
    return cell


@dataclass(slots=True)
class Engine:
    """The service's shared resources, opened and closed by the app's lifespan."""

    settings: Settings
    store: Store
    cache: ByteLRU
    pool: Pool

    async def warm(self) -> None:
        """Compile (or load) every kernel now, so that no request pays for it."""
        await self.pool.run(planner.warm_up)

    async def grid(self, map_id: str) -> Grid:
        """An uploaded map's cells; ``NotFound`` when unknown."""
        grid = await self.store.get_map(map_id)
        if grid is None:
            raise NotFound(
                f"map_id: no map {quote(map_id)}; upload it with POST /maps", field="map_id"
            )
        return grid

    async def analysis(self, map_id: str, params: planner.Params) -> tuple[planner.Analysis, bool]:
        """The map's analysis for ``params`` from the cache (computed once, in the pool, on a
        miss), and whether it was cached."""

        async def compute() -> planner.Analysis:
            return await self.pool.run(_analyse, await self.grid(map_id), params)

        return await self.cache.get_or_compute(analysis_key(map_id, params), compute)

    async def build_plan(
        self, map_id: str, start: Any, goal: Any, preset: str, overrides: dict[str, Any]
    ) -> tuple[planner.Plan, bool]:
        """A new plan with its preview computed, and whether its analysis was cached.

        The planner itself decides whether the plan needs the narrow wave; the waves it asks
        for come from the cache, computed in the worker running the plan on a miss.
        """
        params = planner.resolve_params(preset, **overrides)
        analysis, hit = await self.analysis(map_id, params)
        plan = await self.pool.run(self._plan, map_id, start, goal, preset, params, analysis)
        return plan, hit

    def _plan(
        self,
        map_id: str,
        start: Any,
        goal: Any,
        preset: str,
        params: planner.Params,
        analysis: planner.Analysis,
    ) -> planner.Plan:
        def wave(narrow: bool) -> planner.Wave:
            return self._wave(map_id, params, analysis, goal, narrow)

        plan = planner.plan(
            None, start, goal, preset=preset, analysis=analysis, waves=wave, **params.as_dict()
        )
        plan.summary()  # the preview, now in the pool: responses are built on the event loop
        return plan

    def _wave(
        self,
        map_id: str,
        params: planner.Params,
        analysis: planner.Analysis,
        goal: Any,
        narrow: bool,
    ) -> planner.Wave:
        """The goal wave from the cache, computed in the calling worker on a miss."""
        key = wave_key(map_id, params, goal, narrow)
        compute = lambda: _goal_wave(analysis, goal, params, narrow)  # noqa: E731
        return self.cache.get_or_compute_sync(key, compute)[0]

    async def plan_of(self, record: PlanRecord) -> planner.Plan:
        """The stored plan's arrays: two cache look-ups when warm, else rebuilt from the map."""
        params = planner.Params(**record["params"])
        map_id, goal, narrow = record["map_id"], record["goal"], record["narrow_fallback"]
        analysis = self.cache.peek(analysis_key(map_id, params))
        wave = self.cache.peek(wave_key(map_id, params, goal, narrow))
        if analysis is None or wave is None:
            analysis, _ = await self.analysis(map_id, params)
            wave = await self.pool.run(self._wave, map_id, params, analysis, goal, narrow)
        assert isinstance(analysis, planner.Analysis)
        assert isinstance(wave, planner.Wave)
        return planner.Plan(
            start=(record["start"][0], record["start"][1]),
            goal=(goal[0], goal[1]),
            preset=record["preset"],
            params=params,
            analysis=analysis,
            wave=wave,
            narrow_fallback=narrow,
            elapsed_ms=0.0,
        )


def _analyse(grid: Grid, p: planner.Params) -> planner.Analysis:
    analysis = planner.analyse(
        grid, seal_tunnels=p.seal_tunnels, clean_weight=p.clean_weight, clean_radius=p.clean_radius
    )
    analysis.clearance  # noqa: B018 - computed now, in the pool, so that nbytes is final
    return analysis


def _goal_wave(
    analysis: planner.Analysis, goal: Any, p: planner.Params, narrow: bool
) -> planner.Wave:
    return planner.goal_wave(analysis, goal, diagonal_cost=p.diagonal_cost, narrow=narrow)

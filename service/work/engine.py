"""What every resource shares: the store, the analysis cache, the worker pool, and plans built
from cached analyses and goal waves.

The resource modules (``maps``, ``plans``, ``simulation``) do their work through an
:class:`Engine`. A plan is built once, in the pool (:meth:`Engine.build_plan`); its record keeps
the resolved parameters and whether it took the narrow fallback, so a step finds the plan's
analysis and wave again by key (:meth:`Engine.plan_of`) without resolving or rebuilding anything.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Hashable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import planner
from planner._errors import quote
from planner.analysis.fields import params_key
from planner.render import auto_cell
from schemas import PlanCreate, Point, SimulationCreate
from service.config import Settings
from service.edge.tenants import scoped
from service.errors import NotFound, TooLarge
from service.stores import PlanRecord, Store
from service.work.cache import ByteLRU
from service.work.pool import Pool

__all__ = [
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE",
    "Engine",
    "analysis_key",
    "cell_size",
    "frame_map",
    "overrides",
    "wave_key",
    "where",
]

MAX_IMAGE_SIDE = 8192
"""Pixels on a picture's longer side at most (the picture must also hold at most
``MAX_IMAGE_PIXELS``: a 4096 x 4096 map at 1 pixel a cell)."""
MAX_IMAGE_PIXELS = 4096 * 4096
"""Pixels of a picture at most (a few seconds to draw and compress, ~50 MB while drawn)."""

PLAIN_MEMO = 65536
"""Maps whose plainness (:attr:`planner.RobotMap.plain`) the engine remembers: with it, a
warm plan or step builds its cache keys without reading the map from the store."""


def analysis_key(map_id: str, params: planner.Params, *, plain: bool) -> Hashable:
    """The cache key of a map's analysis for ``params``: :func:`planner.analysis_key` of the
    stored map (``(map_id, *params_key(params, plain=map.plain))``), tagged, and the tenant's
    (see ``service.edge.tenants``)."""
    return ("analysis", scoped(map_id), *params_key(params, plain=plain))


def wave_key(
    map_id: str, params: planner.Params, goal: Any, narrow: bool, *, plain: bool
) -> Hashable:
    """The cache key of a goal wave (``goal`` a cell) over that analysis (``narrow``: over the
    unsealed grid)."""
    key = params_key(params, plain=plain)
    return ("wave", scoped(map_id), *key, tuple(goal), params.diagonal_cost, narrow)


def where(value: list[int] | Point) -> Any:
    """A request's cell (``[row, col]``) or point (``{"x", "y"}``), as the planner takes it."""
    return value.model_dump() if isinstance(value, Point) else value


def overrides(body: PlanCreate | SimulationCreate) -> dict[str, Any]:
    """The planner parameters a request overrides: ``params``, with ``allow_narrow``,
    ``robot_radius`` and ``unknown`` on top (given both ways, they must agree)."""
    out = dict(body.params)
    for name in ("allow_narrow", "robot_radius", "unknown"):
        value = getattr(body, name)
        if value is None:
            continue
        if name in out and out[name] != value:
            msg = (
                f"{name} {quote(value)} and params.{name} {quote(out[name])} disagree; "
                "give one of them"
            )
            raise planner.InvalidInput(msg, field=name)
        out[name] = value
    return out


def frame_map(frame: planner.MapFrame) -> planner.RobotMap:
    """A map of ``frame`` with no content: what :func:`planner.circle_cells` reads (the frame
    only), without the stored map. The occupancy is a zero-copy broadcast view."""
    return planner.RobotMap(np.broadcast_to(np.int8(0), frame.shape), frame)


def cell_size(shape: tuple[int, int], cell: int | None) -> int:
    """Pixels per cell of a picture: the caller's, within the image limit, or the planner's
    legible default (:func:`planner.render.auto_cell`)."""
    side = max(shape)
    if cell is None:
        return auto_cell(shape)
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
    _plain: OrderedDict[str, bool] = field(default_factory=OrderedDict)

    async def warm(self) -> None:
        """Compile (or load) every kernel now, so that no request pays for it."""
        await self.pool.run(planner.warm_up)

    async def robot_map(self, map_id: str) -> planner.RobotMap:
        """An uploaded map; ``NotFound`` when unknown."""
        robot_map = await self.store.get_map(map_id)
        if robot_map is None:
            raise NotFound(
                f"map_id: no map {quote(map_id)}; upload it with POST /maps", field="map_id"
            )
        self.remember(map_id, robot_map)
        return robot_map

    def remember(self, map_id: str, robot_map: planner.RobotMap) -> None:
        """Note whether the map is plain: its cache keys depend on it."""
        self._plain[map_id] = robot_map.plain
        self._plain.move_to_end(map_id)
        while len(self._plain) > PLAIN_MEMO:
            self._plain.popitem(last=False)

    async def plain(self, map_id: str) -> bool:
        """Whether the map is plain (read from the store once, then remembered)."""
        known = self._plain.get(map_id)
        return known if known is not None else (await self.robot_map(map_id)).plain

    async def analysis(self, map_id: str, params: planner.Params) -> tuple[planner.Analysis, bool]:
        """The map's analysis for ``params`` from the cache (computed once, in the pool, on a
        miss), and whether it was cached."""

        async def compute() -> planner.Analysis:
            return await self.pool.run(_analyse, await self.robot_map(map_id), params)

        key = analysis_key(map_id, params, plain=await self.plain(map_id))
        return await self.cache.get_or_compute(key, compute)

    async def build_plan(
        self, map_id: str, start: Any, goal: Any, preset: str, overrides: dict[str, Any]
    ) -> tuple[planner.Plan, bool]:
        """A new plan with its preview computed, and whether its analysis was cached.

        ``start`` and ``goal`` are cells or points (dicts). The planner itself decides whether
        the plan needs the narrow wave; the waves it asks for come from the cache, computed in
        the worker running the plan on a miss.
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
        # The waves are cached by the goal's cell: a point is resolved first.
        cell = analysis.frame.cell_of(goal, name="goal") if isinstance(goal, Mapping) else goal

        def wave(narrow: bool) -> planner.Wave:
            return self._wave(map_id, params, analysis, cell, narrow)

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
        key = wave_key(map_id, params, goal, narrow, plain=analysis.plain)
        compute = lambda: _goal_wave(analysis, goal, params, narrow)  # noqa: E731
        return self.cache.get_or_compute_sync(key, compute)[0]

    async def plan_of(self, record: PlanRecord) -> planner.Plan:
        """The stored plan's arrays: two cache look-ups when warm, else rebuilt from the map."""
        params = planner.Params(**record["params"])
        map_id, goal, narrow = record["map_id"], record["goal"], record["narrow_fallback"]
        plain = record.get("plain", True)  # a record from before maps had frames: a plain map
        analysis = self.cache.peek(analysis_key(map_id, params, plain=plain))
        wave = self.cache.peek(wave_key(map_id, params, goal, narrow, plain=plain))
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


def _analyse(robot_map: planner.RobotMap, p: planner.Params) -> planner.Analysis:
    analysis = planner.analyse_map(robot_map, p)
    analysis.clearance  # noqa: B018 - computed now, in the pool, so that nbytes is final
    return analysis


def _goal_wave(
    analysis: planner.Analysis, goal: Any, p: planner.Params, narrow: bool
) -> planner.Wave:
    return planner.goal_wave(analysis, goal, diagonal_cost=p.diagonal_cost, narrow=narrow)

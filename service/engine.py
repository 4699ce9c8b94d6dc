"""What the endpoints do: maps in, plans built from cached analyses and waves, steps, episodes.

Routers call an :class:`Engine`; it validates what the schemas cannot know (the map, limits from
the settings), runs planner calls in the pool and keeps plans in the store as plain data.
"""

from __future__ import annotations

import hashlib
import secrets
from collections.abc import Hashable
from typing import Any, Literal, NamedTuple

import numpy as np

import planner
from planner.grids import as_cell
from planner.planning import clearance_metrics
from schemas import (
    MapCreate,
    MapPublic,
    PlanCreate,
    PlanDetail,
    PlanPublic,
    SimulationCreate,
    SimulationPublic,
    StepCreate,
    StepPublic,
)
from service.cache import ByteLRU
from service.config import Settings
from service.errors import NotFound, TooLarge
from service.pool import Pool
from service.store import Grid, PlanRecord, Store

__all__ = ["Engine", "map_id_of", "overrides"]

PREVIEW_KEYS = ("path", "length", "arc_cost", "min_clearance", "mean_clearance", "contact_ratio")


def map_id_of(grid: Grid) -> str:
    """The hex SHA-256 of a map's shape and cells: the same for every encoding of one map."""
    h, w = grid.shape
    return hashlib.sha256(f"{h}x{w}:".encode() + grid.tobytes()).hexdigest()


class Engine:
    """The service's work, over one store, one cache and one pool."""

    def __init__(self, settings: Settings, store: Store, cache: ByteLRU, pool: Pool) -> None:
        self.settings = settings
        self.store = store
        self.cache = cache
        self.pool = pool

    async def warm(self) -> None:
        """Compile (or load) every kernel now, so that no request pays for it."""
        await self.pool.run(planner.warm_up)

    # Maps

    async def add_map(self, body: MapCreate) -> tuple[MapPublic, bool]:
        grid = await self.pool.run(self._grid, body)
        map_id = map_id_of(grid)
        created = await self.store.put_map(map_id, grid)
        info = _map_public(map_id, grid)
        if body.start is not None and body.goal is not None:
            info.plan = await self.create_plan(
                map_id, body.start, body.goal, body.preset, overrides(body)
            )
        return info, created

    async def get_map(self, map_id: str) -> MapPublic:
        return _map_public(map_id, await self._map(map_id))

    def _grid(self, body: MapCreate) -> Grid:
        limit = self.settings.max_map_cells
        if body.rows is not None:
            name, height, width = "rows", len(body.rows), len(body.rows[0]) if body.rows else 0
        else:
            assert body.grid is not None
            name, height, width = "grid", len(body.grid), len(body.grid[0]) if body.grid else 0
        # Checked before numpy sees the cells: a map too large is refused without copying it.
        if height * width > limit:
            msg = f"a {height} x {width} map has {height * width} cells; the limit is {limit}"
            raise TooLarge(msg, field=name)
        if body.rows is not None:
            return planner.parse_rows(body.rows)
        return planner.as_grid(body.grid)

    async def _map(self, map_id: str) -> Grid:
        grid = await self.store.get_map(map_id)
        if grid is None:
            raise NotFound(f"map_id: no map {map_id!r}; upload it with POST /maps", field="map_id")
        return grid

    # Plans

    async def create_plan(
        self, map_id: str, start: list[int], goal: list[int], preset: str, params: dict[str, Any]
    ) -> PlanPublic:
        plan, cache_hit = await self._plan(map_id, start, goal, preset, params)
        plan_id = secrets.token_hex(16)
        state = planner.Session(plan).state
        stored = state.as_dict()
        record: PlanRecord = {
            "map_id": map_id,
            "start": list(plan.start),
            "goal": list(plan.goal),
            "preset": preset,
            "params": plan.params.as_dict(),
            "cache_hit": cache_hit,
            "state": stored,
        }
        await self.store.put_plan(plan_id, record, append=stored.pop("trajectory"))
        return PlanPublic.model_validate(_plan_public(plan_id, record, plan, state))

    async def get_plan(self, plan_id: str) -> PlanDetail:
        record = await self._record(plan_id)
        plan = await self._rebuild(record)
        state = await self._state(plan_id, record)
        trajectory = np.asarray(state.trajectory, dtype=np.int64).reshape(-1, 2)
        min_c, mean_c, contact = clearance_metrics(trajectory, plan.analysis)
        metrics = {
            "iterations": state.iteration,
            "moves": len(trajectory) - 1,
            "waits": state.waits,
            "replans": state.replans,
            "path_length": round(state.path_length, 6),
            "arc_cost": round(state.arc_cost, 6),
            "min_clearance": round(min_c, 4),
            "mean_clearance": round(mean_c, 4),
            "contact_ratio": round(contact, 4),
        }
        return PlanDetail.model_validate(
            {
                **_plan_public(plan_id, record, plan, state),
                "iteration": state.iteration,
                "trajectory": trajectory.tolist(),
                "metrics": metrics,
            }
        )

    async def delete_plan(self, plan_id: str) -> None:
        if not await self.store.delete_plan(plan_id):
            raise _unknown_plan(plan_id)

    async def step(self, plan_id: str, body: StepCreate) -> StepPublic:
        limit = self.settings.max_dynamic_obstacles
        if len(body.dynamic_obstacles) > limit:
            msg = f"{len(body.dynamic_obstacles)} dynamic obstacles given; the limit is {limit}"
            raise planner.InvalidInput(msg, field="dynamic_obstacles")
        # Read, step and write back under the plan's lock: concurrent steps never lose a move.
        async with self.store.plan_lock(plan_id):
            record = await self._record(plan_id)
            inputs = await self._inputs(
                record["map_id"],
                record["start"],
                record["goal"],
                record["preset"],
                record["params"],
            )
            plan = _build(inputs)
            # The trajectory log is read only for the paper's tabu list: the wide decision
            # needs none of it, and its step then costs the same at any length of episode.
            if plan.params.decision == "paper":
                trajectory = await self.store.get_trajectory(plan_id)
            else:
                trajectory = [tuple(record["state"]["position"])]
            state = planner.SessionState.from_dict({**record["state"], "trajectory": trajectory})
            session = planner.Session(plan, state)
            obstacles, position, seq = body.dynamic_obstacles, body.position, body.seq
            if session.may_replan:
                step = await self.pool.run(session.step, obstacles, position=position, seq=seq)
            else:
                # Measured: a step that cannot replan is a few microseconds of bounded work, and
                # the trip to a worker thread and back costs 0.1-1 ms; it runs here.
                step = session.step(obstacles, position=position, seq=seq)
            record["state"] = stored = session.state.as_dict()
            moved = stored.pop("trajectory")[len(trajectory) :]
            await self.store.put_plan(plan_id, record, append=moved)
        return StepPublic.model_validate(step.as_dict())

    async def simulate(self, map_id: str, body: SimulationCreate) -> SimulationPublic:
        limit = self.settings.max_dynamic_obstacles
        if body.dynamic_count > limit:
            msg = f"dynamic_count {body.dynamic_count} exceeds the limit of {limit}"
            raise planner.InvalidInput(msg, field="dynamic_count")
        plan, _ = await self._plan(map_id, body.start, body.goal, body.preset, overrides(body))
        episode = await self.pool.run(
            planner.run_episode,
            plan,
            dynamic=body.dynamic_count,
            seed=body.seed,
            max_steps=body.max_steps,
            record=False,  # the answer holds no obstacle cells: keep none
        )
        return SimulationPublic.model_validate(
            {"trajectory": episode.trajectory.tolist(), "metrics": episode.metrics}
        )

    async def _state(self, plan_id: str, record: PlanRecord) -> planner.SessionState:
        """A stored plan's whole state, its trajectory read back from the store's log."""
        trajectory = await self.store.get_trajectory(plan_id)
        return planner.SessionState.from_dict({**record["state"], "trajectory": trajectory})

    async def _record(self, plan_id: str) -> PlanRecord:
        record = await self.store.get_plan(plan_id)
        if record is None:
            raise _unknown_plan(plan_id)
        return record

    async def _rebuild(self, record: PlanRecord) -> planner.Plan:
        """The plan of a stored record: cheap, since its analysis and waves are cached."""
        plan, _ = await self._plan(
            record["map_id"], record["start"], record["goal"], record["preset"], record["params"]
        )
        return plan

    async def _analysis(self, map_id: str, p: planner.Params) -> tuple[planner.Analysis, bool]:
        """The map's analysis for ``p`` from the cache (computed once on a miss)."""
        key = ("analysis", map_id, p.seal_tunnels, p.clean_weight, p.clean_radius)

        async def analyse() -> planner.Analysis:
            return await self.pool.run(_analyse, await self._map(map_id), p)

        return await self.cache.get_or_compute(key, analyse)

    # Pictures

    async def render_map(
        self, map_id: str, preset: str, field: Literal["clean"] | None, cell: int | None
    ) -> bytes:
        analysis, _ = await self._analysis(map_id, planner.resolve_params(preset))
        size = _cell_size(analysis.shape, cell)
        return await self.pool.run(planner.render_map, analysis, field=field, cell=size)

    async def render_plan(
        self, plan_id: str, field: Literal["clean", "kw"] | None, cell: int | None
    ) -> bytes:
        record = await self._record(plan_id)
        plan = await self._rebuild(record)
        trajectory = await self.store.get_trajectory(plan_id)
        size = _cell_size(plan.analysis.shape, cell)
        return await self.pool.run(
            planner.render_plan, plan, trajectory=trajectory, field=field, cell=size
        )

    async def _plan(
        self, map_id: str, start: Any, goal: list[int], preset: str, params: dict[str, Any]
    ) -> tuple[planner.Plan, bool]:
        """A plan on the cached analysis and waves, and whether the analysis was cached."""
        inputs = await self._inputs(map_id, start, goal, preset, params)
        return await self.pool.run(_with_preview, inputs), inputs.cache_hit

    async def _inputs(
        self, map_id: str, start: Any, goal: list[int], preset: str, params: dict[str, Any]
    ) -> _Inputs:
        """What a plan is built from: the request and the cached analysis and waves."""
        p = planner.resolve_params(preset, **params)
        analysis, hit = await self._analysis(map_id, p)
        analysis_key = (map_id, p.seal_tunnels, p.clean_weight, p.clean_radius)

        async def wave(narrow: bool) -> planner.Wave:
            key: Hashable = ("wave", *analysis_key, tuple(goal), p.diagonal_cost, narrow)
            compute = lambda: self.pool.run(  # noqa: E731
                planner.goal_wave, analysis, goal, diagonal_cost=p.diagonal_cost, narrow=narrow
            )
            return (await self.cache.get_or_compute(key, compute))[0]

        # Both waves are fetched here, on the event loop, so that the plan itself (in the pool)
        # never waits on the pool: with a small pool that could deadlock.
        waves = {False: await wave(False)}
        if analysis.sealed and not _reaches(waves[False], analysis, start):
            waves[True] = await wave(True)
        return _Inputs(start, goal, preset, params, analysis, waves, hit)


class _Inputs(NamedTuple):
    start: Any
    goal: list[int]
    preset: str
    params: dict[str, Any]
    analysis: planner.Analysis
    waves: dict[bool, planner.Wave]
    cache_hit: bool


def _build(i: _Inputs) -> planner.Plan:
    return planner.plan(
        None, i.start, i.goal,
        preset=i.preset, analysis=i.analysis, waves=i.waves.__getitem__, **i.params,
    )  # fmt: skip


def _with_preview(i: _Inputs) -> planner.Plan:
    """A plan whose preview path and figures are computed now, in the pool: they are made on
    first use, and the responses that show them are built on the event loop."""
    plan = _build(i)
    plan.summary()
    return plan


MAX_IMAGE_SIDE = 8192
"""Pixels on a picture's longer side at most: a 4096 x 4096 map at 2 pixels a cell."""


def _cell_size(shape: tuple[int, int], cell: int | None) -> int:
    """Pixels per cell: the caller's, within the image limit, or one that makes a picture of
    about 800 pixels (1 to 10 a cell)."""
    side = max(shape)
    if cell is None:
        return max(1, min(10, 800 // side))
    if side * cell > MAX_IMAGE_SIDE:
        msg = (
            f"cell {cell} would draw the {shape[0]} x {shape[1]} map {side * cell} pixels wide; "
            f"the limit is {MAX_IMAGE_SIDE} (use cell <= {max(1, MAX_IMAGE_SIDE // side)})"
        )
        raise planner.InvalidInput(msg, field="cell")
    return cell


def _reaches(wave: planner.Wave, analysis: planner.Analysis, cell: Any) -> bool:
    # An invalid start is left for planner.plan to name; any cell "reaches" until then.
    try:
        r, c = as_cell(cell, analysis.shape, name="start")
    except planner.InvalidInput:
        return True
    return planner.reaches(wave, analysis, (r, c))


def _analyse(grid: Grid, p: planner.Params) -> planner.Analysis:
    analysis = planner.analyse(
        grid, seal_tunnels=p.seal_tunnels, clean_weight=p.clean_weight, clean_radius=p.clean_radius
    )
    analysis.clearance  # noqa: B018 - computed now, in the pool, so that nbytes is final
    return analysis


def overrides(body: MapCreate | PlanCreate | SimulationCreate) -> dict[str, Any]:
    """The planner parameters a request overrides: ``params``, with ``allow_narrow`` on top."""
    if body.allow_narrow is None:
        return dict(body.params)
    return {**body.params, "allow_narrow": body.allow_narrow}


def _unknown_plan(plan_id: str) -> NotFound:
    msg = f"plan_id: no plan {plan_id!r} (unknown, deleted or expired)"
    return NotFound(msg, field="plan_id")


def _map_public(map_id: str, grid: Grid) -> MapPublic:
    h, w = grid.shape
    return MapPublic(map_id=map_id, height=h, width=w, free_cells=int(np.count_nonzero(grid == 0)))


def _plan_public(
    plan_id: str, record: PlanRecord, plan: planner.Plan, state: planner.SessionState
) -> dict[str, Any]:
    s = plan.summary()
    return {
        "plan_id": plan_id,
        "map_id": record["map_id"],
        "start": s["start"],
        "goal": s["goal"],
        "preset": s["preset"],
        "params": s["params"],
        "status": state.status,
        "position": list(state.position),
        "analysis": {
            "gates": s["gates"],
            "tunnels": s["tunnels"],
            "narrow_fallback": s["narrow_fallback"],
            "cache_hit": record["cache_hit"],
            "analysis_ms": s["analysis_ms"],
        },
        "preview": {key: s[key] for key in PREVIEW_KEYS},
    }

"""What every resource shares: the store, the analysis cache, the worker pool, and plans built
from cached analyses and goal waves.

The resource modules (``maps``, ``plans``, ``simulation``) do their work through an
:class:`Engine`. A plan is built once, in the pool (:meth:`Engine.build_plan`); its record keeps
the resolved parameters and whether it took the narrow fallback, so a step finds the plan again
(:meth:`Engine.plan_of`: one look-up in a small memo of plans when warm, else the analysis and
wave by key) without resolving or rebuilding anything.

Goal waves are resumable (:class:`planner.ResumableWave`): settled from the goal only as far as
the robots sharing it have needed, so a plan costs what the region it explores costs, not the
map. The cache charges a wave again whenever it grows; an evicted wave is rebuilt on demand, and
its plans with it. A step runs on the event loop only when it cannot search and reads only
settled cells (:meth:`Engine.step`).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import threading
import weakref
from collections import OrderedDict
from collections.abc import Hashable
from dataclasses import dataclass, field
from typing import Any

import planner
from planner import Unsettled, params_key
from planner.motion.robots import SEARCH_SECONDS
from service.config import Settings
from service.stores import PlanRecord, Store
from service.stores.base import unknown_map
from service.tenants import scoped
from service.work.cache import ByteLRU
from service.work.pool import Pool
from service.work.records import plan_ends, plan_key, plan_legs, plan_of_record

__all__ = [
    "Engine",
    "analysis_key",
    "wave_key",
]

OBSTACLES_ON_LOOP = 4096
"""Blocked cells a step may have and still be decided on the event loop (circles covering a
whole map are a million cells: those steps go to a step worker)."""

PLAIN_MEMO = 65536
"""Maps whose plainness (:attr:`planner.RobotMap.plain`) the engine remembers: with it, a
warm plan or step builds its cache keys without reading the map from the store."""


def analysis_key(map_id: str, params: planner.Params, *, plain: bool) -> Hashable:
    """The cache key of a map's analysis for ``params``: :func:`planner.analysis_key` of the
    stored map (``(map_id, *params_key(params, plain=map.plain))``), tagged, and the tenant's
    (see ``service.tenants``)."""
    return ("analysis", scoped(map_id), *params_key(params, plain=plain))


def wave_key(
    map_id: str, params: planner.Params, goal: Any, narrow: bool, *, plain: bool
) -> Hashable:
    """The cache key of a goal wave (``goal`` a cell) over that analysis (``narrow``: over the
    unsealed grid)."""
    key = params_key(params, plain=plain)
    return ("wave", scoped(map_id), *key, tuple(goal), params.diagonal_cost, narrow)


PLAN_MEMO = 1024
"""Plans the engine keeps built (their arrays are the cache's: a plan adds its path and a few
numbers), so that a warm step finds its plan with one look-up."""


@dataclass(slots=True)
class Engine:
    """The service's shared resources, opened and closed by the app's lifespan."""

    settings: Settings
    store: Store
    cache: ByteLRU
    pool: Pool
    _plain: OrderedDict[str, bool] = field(default_factory=OrderedDict)
    # A plan, and the cache keys of its analysis and wave (touched on every use).
    _plans: OrderedDict[Hashable, tuple[planner.Plan, tuple[Hashable, Hashable]]] = field(
        default_factory=OrderedDict
    )
    _plans_lock: threading.Lock = field(default_factory=threading.Lock)

    def __post_init__(self) -> None:
        self.cache.on_evict = self._forget

    def _forget(self, key: Hashable, value: Any) -> None:
        """An analysis or wave left the cache: so do the memo's plans over it (rebuilt on their
        next step over the cache's new one), which would otherwise keep it alive. A route's
        legs share its analysis, and legs to the same cell their wave: a plan goes once."""
        gone = {id(value)}
        if isinstance(value, planner.ResumableWave) and value.handed_over is not None:
            gone.add(id(value.handed_over))

        def over(plan: planner.Plan) -> bool:
            parts = (plan, *(plan.route.legs if plan.route is not None else ()))
            return any(id(p.wave) in gone or id(p.analysis) in gone for p in parts)

        with self._plans_lock:
            for k in [k for k, (plan, _) in self._plans.items() if over(plan)]:
                del self._plans[k]

    @property
    def search_seconds(self) -> float:
        """How long a plan's footprint or car search may run: its own bound, and half the
        request's timeout (the analysis, the goal wave and the answer have the rest): out of
        time, a ``422`` ``NO_VALID_PATH`` that says so, not a ``504``."""
        return min(SEARCH_SECONDS, 0.5 * self.settings.request_timeout_seconds)

    def _remember_plan(self, key: Hashable, map_id: str, plan: planner.Plan) -> None:
        wave = plan.wave
        p, plain = plan.params, plan.analysis.plain
        last = plan if plan.route is None else plan.route.legs[-1]  # whose wave the plan's is
        keys = (
            analysis_key(map_id, p, plain=plain),
            wave_key(map_id, p, last.goal, last.narrow_fallback, plain=plain),
        )
        if isinstance(wave, planner.ResumableWave) and wave.handed_over is not None:
            # Its steps read the whole-map wave directly: no lock, nothing left to settle.
            plan = dataclasses.replace(plan, wave=wave.handed_over)
        with self._plans_lock:
            # Checked holding the memo's lock: an eviction after the check is forgotten (the
            # cache tells it, its lock released) only once the plan is in the memo.
            if (
                self.cache.peek(keys[0]) is not plan.analysis
                or self.cache.peek(keys[1]) is not wave
            ):
                # Evicted while the plan was built (a growing wave may even evict itself): not
                # kept, or the memo would hold arrays the cache no longer counts.
                return
            self._plans[key] = (plan, keys)
            self._plans.move_to_end(key)
            while len(self._plans) > PLAN_MEMO:
                self._plans.popitem(last=False)

    async def warm(self, wait_seconds: float) -> asyncio.Future[None] | None:
        """Compile (or load from numba's cache) every kernel, the kernels of a service's plans
        and steps first, on a thread of its own; wait for those (``wait_seconds`` at most). None
        when every kernel is done (no request pays for one), else the warm-up still running:
        meanwhile a request waits for the kernels it needs, and steps run on step workers (a
        kernel compiled on the event loop would hold every request)."""
        loop = asyncio.get_running_loop()
        served: asyncio.Future[None] = loop.create_future()
        done: asyncio.Future[None] = loop.create_future()

        def tell(future: asyncio.Future[None], failure: BaseException | None = None) -> None:
            with contextlib.suppress(RuntimeError):  # the service stopped meanwhile
                loop.call_soon_threadsafe(_settle, future, failure)

        def warm_up() -> None:
            failure: BaseException | None = None
            try:
                planner.warm_up(served=lambda: tell(served))
            except BaseException as exc:  # handed to the waiters
                failure = exc
            tell(served, failure)
            tell(done, failure)

        # A daemon thread: a service stopped while compiling does not wait for the compiler.
        threading.Thread(target=warm_up, name="warm-up", daemon=True).start()
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(asyncio.shield(served), timeout=wait_seconds)
        if not done.done():
            return done
        done.result()  # a failure raised here, as before
        self.pool.warm = True
        return None

    async def robot_map(self, map_id: str) -> planner.RobotMap:
        """An uploaded map; ``NotFound`` when unknown."""
        robot_map = await self.store.get_map(map_id)
        if robot_map is None:
            raise unknown_map(map_id)
        self.remember(map_id, robot_map)
        return robot_map

    async def require_map(self, map_id: str) -> None:
        """``NotFound`` naming ``map_id`` unless the store holds the map now: what is cached of
        a map (its analyses, passages) outlives it, and must not answer for it."""
        if not await self.store.has_map(map_id):
            raise unknown_map(map_id)

    def remember(self, map_id: str, robot_map: planner.RobotMap) -> None:
        """Note whether the tenant's map is plain: its cache keys depend on it (another
        tenant's note never stands for the map: it must read the map from the store)."""
        key = scoped(map_id)
        self._plain[key] = robot_map.plain
        self._plain.move_to_end(key)
        while len(self._plain) > PLAIN_MEMO:
            self._plain.popitem(last=False)

    async def plain(self, map_id: str) -> bool:
        """Whether the map is plain (read from the store once, then remembered)."""
        known = self._plain.get(scoped(map_id))
        return known if known is not None else (await self.robot_map(map_id)).plain

    async def analysis(self, map_id: str, params: planner.Params) -> tuple[planner.Analysis, bool]:
        """The map's analysis for ``params`` from the cache (computed once, in the pool, on a
        miss), and whether it was cached."""

        async def compute() -> planner.Analysis:
            robot_map = await self.robot_map(map_id)
            return await self.pool.run(_analyse, robot_map, params, self._base(robot_map, params))

        key = analysis_key(map_id, params, plain=await self.plain(map_id))
        return await self.cache.get_or_compute(key, compute)

    def _base(self, robot_map: planner.RobotMap, params: planner.Params) -> planner.Analysis | None:
        """The cached analysis of the map a zoned map was zoned from, for ``params`` (None: not
        a zoned map, or its base's analysis not in the cache): a zoned map's analysis is
        derived from it (:func:`planner.rezone_analysis`), else computed afresh."""
        if robot_map.zones is None:
            return None
        base_id = robot_map.zones.base_map_id
        plain = self._plain.get(scoped(base_id))
        if plain is None:
            return None
        base = self.cache.peek(analysis_key(base_id, params, plain=plain))
        return base if isinstance(base, planner.Analysis) else None

    async def build_plan(
        self,
        map_id: str,
        start: Any,
        goal: Any,
        preset: str,
        overrides: dict[str, Any],
        goal_tolerance: float = 0.0,
        *,
        preview: bool = True,
        waypoints: Any = None,
    ) -> tuple[planner.Plan, bool]:
        """A new plan with its preview computed (with ``preview``; else its path only: a
        simulation), and whether its analysis was cached.

        ``start`` and ``goal`` are cells or points (dicts). The planner itself decides whether
        the plan needs the narrow wave; the waves it asks for come from the cache, computed in
        the worker running the plan on a miss. Through ``waypoints``, each leg's wave too.
        """
        params = planner.resolve_params(preset, **overrides)
        analysis, hit = await self.analysis(map_id, params)
        plan = await self.pool.run(
            self._plan,
            map_id,
            start,
            goal,
            preset,
            params,
            analysis,
            goal_tolerance,
            preview,
            waypoints,
        )
        record = {
            "map_id": map_id, "start": plan.start, "goal": plan.goal, "preset": plan.preset,
            "params": plan.params.as_dict(), "narrow_fallback": plan.narrow_fallback,
            "plain": analysis.plain, "ends": plan_ends(plan), "legs": plan_legs(plan),
        }  # fmt: skip
        self._remember_plan(plan_key(record), map_id, plan)
        return plan, hit

    def _plan(
        self,
        map_id: str,
        start: Any,
        goal: Any,
        preset: str,
        params: planner.Params,
        analysis: planner.Analysis,
        goal_tolerance: float,
        preview: bool,
        waypoints: Any = None,
    ) -> planner.Plan:
        # The waves are cached by the goal's cell.
        def wave(cell: tuple[int, int], narrow: bool) -> planner.Wave:
            return self._wave(map_id, params, analysis, cell, narrow)

        plan = planner.plan(
            None, start, goal, preset=preset, analysis=analysis, waves=wave,
            goal_tolerance=goal_tolerance, waypoints=waypoints,
            search_seconds=self.search_seconds, **params.as_dict(),
        )  # fmt: skip
        if preview:  # the preview, now in the pool: responses are built on the event loop
            plan.summary()
        else:  # a simulation walks the path; it answers no poses
            plan.path  # noqa: B018
        if plan.route is not None:
            plan.route.costs  # noqa: B018 - read now, in the pool: a record keeps them
        return plan

    def _wave(
        self,
        map_id: str,
        params: planner.Params,
        analysis: planner.Analysis,
        goal: Any,
        narrow: bool,
    ) -> planner.Wave:
        """The goal wave from the cache; on a miss a new resumable one (nothing settled yet:
        microseconds), which the cache charges again whenever it grows."""
        key = wave_key(map_id, params, goal, narrow, plain=analysis.plain)

        def compute() -> planner.ResumableWave:
            wave = planner.resumable_wave(
                analysis, goal, diagonal_cost=params.diagonal_cost, narrow=narrow
            )
            # A weak reference: the wave must not keep itself alive through its own hook.
            ref = weakref.ref(wave)

            def resized() -> None:
                grown = ref()
                if grown is not None:
                    self.cache.recharge(key, grown)

            wave.on_resize = resized
            return wave

        return self.cache.get_or_compute_sync(key, compute)[0]

    async def plan_of(self, record: PlanRecord, *, preview: bool = False) -> planner.Plan:
        """The stored plan: one look-up in the memo of plans when warm, else rebuilt over the
        cached analysis and wave (either recomputed if evicted). With ``preview``, its path and
        figures are computed (in the pool, if not yet): a response is built from them."""
        key = plan_key(record)
        with self._plans_lock:
            memo = self._plans.get(key)
            if memo is not None:
                self._plans.move_to_end(key)
        if memo is not None:
            plan, keys = memo
            self.cache.touch(*keys)  # its analysis and wave, in use: the last to evict
        else:
            plan = await self._rebuild(record)
            self._remember_plan(key, record["map_id"], plan)
        if preview and "poses" not in vars(plan):
            # The walk down the wave may resume its searches: off the event loop.
            await self.pool.run(plan.summary)
        return plan

    async def _rebuild(self, record: PlanRecord) -> planner.Plan:
        params = planner.Params(**record["params"])
        map_id = record["map_id"]
        plain = record.get("plain", True)  # a record from before maps had frames: a plain map
        analysis = self.cache.peek(analysis_key(map_id, params, plain=plain))
        if analysis is None:
            analysis, _ = await self.analysis(map_id, params)
        assert isinstance(analysis, planner.Analysis)
        legs = record.get("legs")
        if not legs:
            return self._rebuild_leg(record, params, analysis)
        plans = [self._rebuild_leg({**record, **leg}, params, analysis) for leg in legs]
        return planner.route_of(plans, [leg["cost"] for leg in legs])

    def _rebuild_leg(
        self, record: PlanRecord, params: planner.Params, analysis: planner.Analysis
    ) -> planner.Plan:
        """A plan (or a route's leg) from its record, over the cached analysis and wave."""
        map_id, goal, narrow = record["map_id"], record["goal"], record["narrow_fallback"]
        wave = self._wave(map_id, params, analysis, goal, narrow)
        return plan_of_record(record, params, analysis, wave, self.search_seconds)

    async def step(
        self, session: planner.Session, obstacles: Any, *, position: Any, seq: int | None
    ) -> planner.Step:
        """The session's step (its state is then the step's). On the event loop when it is a
        bounded look around the robot (microseconds; the trip to a worker and back costs
        0.1-1 ms): it cannot replan, and it reads only what its wave has settled, the wave held
        meanwhile so that no other thread grows it. Any other step runs on a step worker
        (never queued behind analyses): it may search (A*, up to the whole map), or wait for
        the thread growing its wave."""
        wave = session.plan.wave
        # Before the warm-up's end a step may need a kernel not compiled yet: never on the loop.
        if len(obstacles) > OBSTACLES_ON_LOOP or not self.pool.warm:
            return await self.pool.run_step(session.step, obstacles, position=position, seq=seq)
        if not isinstance(wave, planner.ResumableWave):
            if session.may_replan_at(position, obstacles):
                return await self.pool.run_step(session.step, obstacles, position=position, seq=seq)
            return session.step(obstacles, position=position, seq=seq)
        if wave.hold():
            try:
                # Tried on a copy: a step that finds its cells unsettled is abandoned midway
                # (a whole-map wave has every cell settled: no copy needed).
                trial = session
                if wave.resumable:
                    trial = planner.Session(session.route, session.state.copy())
                if not trial.may_replan_at(position, obstacles):
                    step = trial.step(obstacles, position=position, seq=seq)
                    session.state = trial.state
                    return step
            except Unsettled:
                pass
            finally:
                wave.release()
        return await self.pool.run_step(session.step, obstacles, position=position, seq=seq)


def _settle(done: asyncio.Future[None], exc: BaseException | None) -> None:
    if done.done():  # told twice: the first word stands
        return
    if exc is None:
        done.set_result(None)
    else:
        done.set_exception(exc)


def _analyse(
    robot_map: planner.RobotMap, p: planner.Params, base: planner.Analysis | None = None
) -> planner.Analysis:
    derived = None if base is None else planner.rezone_analysis(base, robot_map, p)
    analysis = planner.analyse_map(robot_map, p) if derived is None else derived[0]
    analysis.clearance  # noqa: B018 - computed now, in the pool, so that nbytes is final
    if analysis.zones is not None:
        analysis.zones.speed_index()  # built now, in the pool: steps look caps up through it
    return analysis

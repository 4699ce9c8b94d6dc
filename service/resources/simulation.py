"""The paper's experiment over HTTP: one seeded episode among randomly moving obstacles."""

from __future__ import annotations

import planner
from schemas import SimulationCreate
from service.edge.cancel import cancelled
from service.errors import TimedOut
from service.resources.bodies import overrides, where
from service.work.engine import Engine

__all__ = ["simulate"]


async def simulate(engine: Engine, map_id: str, body: SimulationCreate) -> planner.Episode:
    limit = engine.settings.max_dynamic_obstacles
    if body.dynamic_count > limit:
        msg = f"dynamic_count {body.dynamic_count} exceeds the limit of {limit}"
        raise planner.InvalidInput(msg, field="dynamic_count")
    most = engine.settings.max_simulation_steps
    if body.max_steps is not None and body.max_steps > most:
        msg = f"max_steps {body.max_steps} exceeds PLANNER_MAX_SIMULATION_STEPS ({most})"
        raise planner.InvalidInput(msg, field="max_steps")
    await engine.require_map(map_id)
    plan, _ = await engine.build_plan(
        map_id, where(body.start), where(body.goal), body.preset, overrides(body),
        goal_tolerance=body.goal_tolerance, preview=False,
    )  # fmt: skip
    # The episode runs in chunks, between which it stops once its request is cancelled (the
    # client went away, or PLANNER_REQUEST_TIMEOUT_SECONDS passed): its worker is freed soon.
    flag = cancelled()
    h, w = plan.analysis.shape
    steps = body.max_steps if body.max_steps is not None else 4 * (h + w) + 4 * len(plan.path)
    episode = await engine.pool.run(
        planner.run_episode,
        plan,
        dynamic_count=body.dynamic_count,
        seed=body.seed,
        max_steps=min(steps, most),
        obstacle_motion=body.obstacle_motion,
        record=False,  # the answer holds no obstacle cells: keep none
        stop=flag.is_set,
    )
    if flag.is_set():
        raise TimedOut("the simulation was stopped before its end (its request was cancelled)")
    return episode

"""The paper's experiment over HTTP: one seeded episode among randomly moving obstacles."""

from __future__ import annotations

import planner
from schemas import SimulationCreate
from service.engine import Engine, overrides, where

__all__ = ["simulate"]


async def simulate(engine: Engine, map_id: str, body: SimulationCreate) -> planner.Episode:
    limit = engine.settings.max_dynamic_obstacles
    if body.dynamic_count > limit:
        msg = f"dynamic_count {body.dynamic_count} exceeds the limit of {limit}"
        raise planner.InvalidInput(msg, field="dynamic_count")
    plan, _ = await engine.build_plan(
        map_id, where(body.start), where(body.goal), body.preset, overrides(body)
    )
    return await engine.pool.run(
        planner.run_episode,
        plan,
        dynamic_count=body.dynamic_count,
        seed=body.seed,
        max_steps=body.max_steps,
        obstacle_motion=body.obstacle_motion,
        record=False,  # the answer holds no obstacle cells: keep none
    )

"""The service's in-process step: load the plan's state, decide, save it (no HTTP, no JSON).

Times the service's step function itself over the memory store, with the analysis and wave
already cached, on a 1024 x 1024 map with 20% obstacles and 10 dynamic obstacles a step. Run it
on two checkouts to compare them: ``python benchmarks/engine_step.py [--label NAME]``.
"""

from __future__ import annotations

import argparse
import asyncio
import platform
import statistics
import time
from typing import Any

import numpy as np

from schemas import MapCreate, PlanCreate, StepCreate
from service.main import create_app

SIZE = 1024


async def run(steps: int) -> dict[str, float]:
    app = create_app()
    async with app.router.lifespan_context(app):
        rng = np.random.default_rng(0)
        grid = (rng.random((SIZE, SIZE)) < 0.2).astype(np.uint8)
        grid[:3, :3] = grid[-3:, -3:] = 0
        step, create = _entry_points(app)
        plan_id = await create(grid, [1, 1], [SIZE - 2, SIZE - 2])
        obstacles = [[int(r), int(c)] for r, c in rng.integers(0, SIZE, size=(10, 2))]
        obstacles = [cell for cell in obstacles if grid[cell[0], cell[1]] == 0]
        body = StepCreate.model_validate({"dynamic_obstacles": obstacles})
        for _ in range(20):  # warm
            await step(plan_id, body)
        times = []
        for _ in range(steps):
            t0 = time.perf_counter()
            await step(plan_id, body)
            times.append(time.perf_counter() - t0)
    times.sort()
    return {
        "median_us": statistics.median(times) * 1e6,
        "p90_us": times[int(0.9 * len(times))] * 1e6,
        "p99_us": times[int(0.99 * len(times))] * 1e6,
    }


def _entry_points(app: Any) -> tuple[Any, Any]:
    """The step and plan-creation functions of this checkout (the layout changed over time)."""
    engine = app.state.engine
    try:
        from service.resources import (
            maps,
            plans,  # the layout after issue 10
        )
    except ImportError:

        async def create_old(grid: Any, start: list[int], goal: list[int]) -> str:
            info, _ = await engine.add_map(MapCreate.model_validate({"grid": grid.tolist()}))
            plan = await engine.create_plan(info.map_id, start, goal, "wide", {})
            return str(plan.plan_id)

        return engine.step, create_old

    async def step(plan_id: str, body: StepCreate) -> Any:
        return await plans.step(engine, plan_id, body)

    async def create(grid: Any, start: list[int], goal: list[int]) -> str:
        info, _ = await maps.add_map(engine, MapCreate.model_validate({"grid": grid.tolist()}))
        body = PlanCreate.model_validate({"map_id": info.map_id, "start": start, "goal": goal})
        plan = await plans.create_plan(engine, body)
        return str(plan.plan_id)

    return step, create


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--label", default="this checkout")
    args = parser.parse_args()
    result = asyncio.run(run(args.steps))
    figures = ", ".join(f"{k} {v:.1f}" for k, v in result.items())
    print(f"{args.label}: in-process step on {SIZE}^2, {platform.processor() or ''} {figures}")


if __name__ == "__main__":
    main()

"""The FastAPI application: ``create_app(settings)`` and ``app``, which uvicorn serves."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI

from service import errors
from service.api import api_router
from service.auth import ApiKeys
from service.cache import ByteLRU
from service.config import Settings
from service.engine import Engine
from service.middleware import BodyLimit
from service.pool import Pool
from service.stores import open_store

__all__ = ["app", "create_app"]

DESCRIPTION = """Wide-free-space path planning on occupancy grids, after Hasan, Abdullah & Saleh
(2023). Upload a map, plan from a start to a goal, then step a robot along the plan while
reporting the dynamic obstacles it sees; or simulate the paper's whole experiment at once."""


TAGS = [
    {"name": "maps", "description": "Upload occupancy grids; draw them with their analysis."},
    {"name": "plans", "description": "Plan, then step the robot among dynamic obstacles."},
    {"name": "simulation", "description": "The paper's experiment: a whole seeded episode."},
    {"name": "service", "description": "Health and cache statistics."},
]
"""The order of the groups in ``/docs`` (routes are registered hot path first)."""


@asynccontextmanager
async def lifespan(app: FastAPI) -> AsyncIterator[None]:
    """Open the store, the cache and the pool; compile the kernels before the first request."""
    settings: Settings = app.state.settings
    store = open_store(
        settings.store_url,
        ttl_seconds=settings.plan_ttl_seconds,
        map_bytes=settings.map_store_bytes,
        map_ttl_seconds=settings.map_ttl_seconds,
        shares=max(1, len(settings.keys)),
    )
    pool = Pool(
        settings.pool_size, step_size=settings.step_pool_size, max_queued=settings.max_queued_jobs
    )
    cache = ByteLRU(settings.cache_bytes, shares=max(1, len(settings.keys)))
    engine = Engine(settings, store, cache, pool)
    try:
        await engine.warm()
        app.state.engine = engine
        yield
    finally:
        pool.close()
        await store.close()


def create_app(settings: Settings | None = None) -> FastAPI:
    """The service configured by ``settings`` (default: from the ``PLANNER_*`` environment)."""
    settings = settings if settings is not None else Settings()
    app = FastAPI(
        title="Wide-free-space path planner",
        version="1.0.0",
        description=DESCRIPTION,
        lifespan=lifespan,
        openapi_tags=TAGS,
    )
    app.state.settings = settings
    errors.install(app)
    app.add_middleware(
        BodyLimit,
        max_bytes=settings.max_body_bytes,
        max_step_bytes=settings.max_step_body_bytes,
        body_timeout=settings.body_timeout_seconds,
        request_timeout=settings.request_timeout_seconds,
    )
    app.add_middleware(ApiKeys, keys=settings.keys)  # outermost: no key, nothing is read
    app.include_router(api_router)
    return app


app = create_app()

"""The FastAPI application: ``create_app(settings)`` and ``app``, which uvicorn serves."""

from __future__ import annotations

import asyncio
import functools
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles

from schemas import StepCreate
from service import errors
from service.api import routers
from service.api.routes.plans import add_step_route
from service.config import Settings
from service.edge.middleware import Edge
from service.ops import docs
from service.ops.logs import LOG, REQUEST_LINES
from service.ops.metrics import Metrics
from service.stores import Store, open_store
from service.viewer.events import open_bus
from service.work.cache import ByteLRU
from service.work.engine import Engine
from service.work.pool import Pool

__all__ = ["app", "create_app", "store_name"]

DESCRIPTION = """Wide-free-space path planning on occupancy grids, after Hasan, Abdullah & Saleh
(2023). Upload a map, plan from a start to a goal, then step a robot along the plan while
reporting the dynamic obstacles it sees; or simulate the paper's whole experiment at once."""


TAGS = [
    {"name": "maps", "description": "Upload occupancy grids; draw them with their analysis."},
    {"name": "plans", "description": "Plan, then step the robot among dynamic obstacles."},
    {"name": "simulation", "description": "The paper's experiment: a whole seeded episode."},
    {"name": "service", "description": "Health and cache statistics."},
]
"""The order of the groups in ``/docs``."""


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
        max_plans=settings.max_plans_per_tenant,
    )
    pool = Pool(
        settings.pool_size, step_size=settings.step_pool_size, max_queued=settings.max_queued_jobs,
        tenants=len(settings.keys) > 1,
    )  # fmt: skip
    cache = ByteLRU(settings.cache_bytes, shares=max(1, len(settings.keys)))
    engine = Engine(settings, store, cache, pool)
    # Steps for the live viewer.
    app.state.bus = bus = open_bus(
        settings.store_url,
        max_bytes=settings.stream_queue_bytes,
        max_streams=settings.max_streams_per_tenant,
    )
    # What start-up lines and /readyz say: never the store URL, which may hold a password.
    facts = {"store": store_name(store), "pool_size": pool.size}
    try:
        LOG.info("warming up: compiling the planner kernels", extra={"fields": facts})
        began = time.perf_counter()
        rest = await engine.warm(settings.warmup_wait_seconds)
        pool.serving = True
        facts["warmup_seconds"] = round(time.perf_counter() - began, 3)
        LOG.info("warmed up", extra={"fields": facts})
        if rest is not None:
            LOG.info("warming up the rest", extra={"fields": facts})
            rest.add_done_callback(functools.partial(_warmed, pool, began))
        app.state.startup = facts
        app.state.started = time.monotonic()
        app.state.engine = engine
        app.state.metrics.engine = engine
        yield
    finally:
        REQUEST_LINES.flush()  # the request lines still buffered
        app.state.metrics.engine = None
        pool.close()
        await bus.close()
        await store.close()


def _warmed(pool: Pool, began: float, rest: asyncio.Future[None]) -> None:
    """The background warm-up's end: every kernel compiled (or its failure logged)."""
    if rest.cancelled() or rest.exception() is not None:
        LOG.error("the warm-up failed", exc_info=None if rest.cancelled() else rest.exception())
        return
    pool.warm = True
    seconds = round(time.perf_counter() - began, 3)
    LOG.info("warmed up the rest", extra={"fields": {"background_seconds": seconds}})


def store_name(store: Store) -> str:
    """``memory``, or ``redis host:port`` (or ``redis /path.sock``): no credentials."""
    address = getattr(store, "address", None)
    return store.kind if address is None else f"{store.kind} {address}"


def create_app(settings: Settings | None = None) -> FastAPI:
    """The service configured by ``settings`` (default: from the ``PLANNER_*`` environment)."""
    settings = settings if settings is not None else Settings()
    app = FastAPI(
        title="Wide-free-space path planner",
        version="1.0.0",
        description=DESCRIPTION,
        lifespan=lifespan,
        openapi_tags=TAGS,
        docs_url=None,  # served by service.ops.docs, with no CDN
        redoc_url=None,
        # FastAPI's native OpenTelemetry off: the service's own metrics (/metrics) and request
        # lines cover it.
        telemetry={"tracing": False, "metrics": False, "logs": False},
    )
    app.state.settings = settings
    app.state.metrics = Metrics()
    errors.install(app)
    step = add_step_route(app)  # the hot route, matched before the routers' ones
    for router in routers:  # each directly, the plans first
        app.include_router(router)
    # The map pages' shared script (pan and zoom), behind the key as the pages are.
    app.mount("/viewer", StaticFiles(packages=[("service.viewer", "static")]), name="viewer")
    app.add_middleware(
        Edge,
        metrics=app.state.metrics,
        # To label the requests it refuses before routing by the route they asked for.
        routes=[step, *(route for router in routers for route in router.routes)],
        keys=settings.keys,
        max_bytes=settings.max_body_bytes,
        max_step_bytes=settings.max_step_body_bytes,
        body_timeout=settings.body_timeout_seconds,
        request_timeout=settings.request_timeout_seconds,
        max_requests=settings.max_requests,
    )
    docs.install(app)
    docs.document_models(app, StepCreate)  # the step reads its body itself
    return app


app = create_app()

"""``/healthz`` (liveness: the process answers) and ``/readyz`` (readiness: the store answers and
the pool is warm), for load balancers and orchestrators."""

from __future__ import annotations

import time

from fastapi import APIRouter, Request, Response, status

from schemas import CacheStats, LivePublic, PoolStats, ReadyPublic, StoreHealth
from service.api.deps import EngineDep

__all__ = ["router"]

router = APIRouter(tags=["service"])

_STARTED = time.monotonic()


@router.get("/healthz", summary="Liveness: the process is up")
async def healthz(request: Request) -> LivePublic:
    """Always `200` while the process serves: it asks nothing of the store or the pool, so a
    store that is down does not get healthy replicas restarted. Use `/readyz` to know whether
    requests can be served."""
    started = getattr(request.app.state, "started", _STARTED)
    return LivePublic(uptime_seconds=round(time.monotonic() - started, 3))


@router.get(
    "/readyz",
    summary="Readiness: the store answers and the warm-up is done or had its time",
    responses={503: {"model": ReadyPublic, "description": "Not ready: see `store`, `pool`."}},
)
async def readyz(engine: EngineDep, response: Response) -> ReadyPublic:
    """`200` with `status: ok` when the store answers and the kernels are compiled, or had
    `PLANNER_WARMUP_WAIT_SECONDS` to compile (`pool.warm` says when all are: the rest compile in
    the background); `503` with `status: unavailable` otherwise, the store's reason under
    `store.detail`. Recovers by itself when the store comes back. Also shows the pool's load and
    the cache's figures."""
    problem = await engine.store.check()
    pool = engine.pool
    ready = problem is None and pool.serving
    if not ready:
        response.status_code = status.HTTP_503_SERVICE_UNAVAILABLE
    c = engine.cache
    stats = CacheStats(
        entries=len(c), bytes=c.bytes, max_bytes=c.max_bytes,
        hits=c.hits, misses=c.misses, evictions=c.evictions,
    )  # fmt: skip
    store = StoreHealth.model_validate(
        {"kind": engine.store.kind, "up": problem is None, "detail": problem}
    )
    return ReadyPublic(
        status="ok" if ready else "unavailable",
        store=store,
        pool=PoolStats(size=pool.size, busy=pool.busy, queued=pool.queued, warm=pool.warm),
        cache=stats,
    )

"""``/healthz``: the service answers, whether its store does, and how its cache stands."""

from __future__ import annotations

from fastapi import APIRouter, Response, status

from schemas import CacheStats, HealthPublic, StoreHealth
from service.api.deps import EngineDep

__all__ = ["router"]

router = APIRouter(tags=["service"])


@router.get(
    "/healthz",
    summary="Liveness and the store's state, with cache statistics",
    responses={503: {"model": HealthPublic, "description": "The store does not answer."}},
)
async def healthz(engine: EngineDep, response: Response) -> HealthPublic:
    """`200` with `status: ok` when the store answers; `503` with `status: unavailable` and the
    reason under `store.detail` while it does not (the container's `HEALTHCHECK` then fails).
    Answers at once, even while the pool is busy with long analyses."""
    problem = await engine.store.check()
    if problem is not None:
        response.status_code = status.HTTP_503_SERVICE_UNAVAILABLE
    c = engine.cache
    stats = CacheStats(
        entries=len(c), bytes=c.bytes, max_bytes=c.max_bytes,
        hits=c.hits, misses=c.misses, evictions=c.evictions,
    )  # fmt: skip
    store = StoreHealth.model_validate(
        {"kind": engine.store.kind, "up": problem is None, "detail": problem}
    )
    return HealthPublic(status="ok" if problem is None else "unavailable", store=store, cache=stats)

"""``/healthz``: the service answers, and how its cache stands."""

from __future__ import annotations

from fastapi import APIRouter

from schemas import CacheStats, HealthPublic
from service.api.deps import EngineDep

__all__ = ["router"]

router = APIRouter(tags=["service"])


@router.get("/healthz", summary="Liveness, with cache statistics")
async def healthz(engine: EngineDep) -> HealthPublic:
    """Answers at once, even while the pool is busy with long analyses."""
    c = engine.cache
    stats = CacheStats(
        entries=len(c), bytes=c.bytes, max_bytes=c.max_bytes,
        hits=c.hits, misses=c.misses, evictions=c.evictions,
    )  # fmt: skip
    return HealthPublic(cache=stats)

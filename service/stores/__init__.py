"""Where maps and plans live, chosen by ``PLANNER_STORE_URL``'s scheme in :func:`open_store`.

Store (``base``)            the interface and the formats every store keeps
├── MemoryStore (``memory``)  this process only: ``memory://``
└── RedisStore  (``redis``)   shared by replicas: ``redis://``, ``rediss://``, ``unix://``;
                              its parts: plans (``redis_plans``), fleets (``redis_fleets``),
                              the live layer (``redis_live``), on one client (``redis_link``)
"""

from __future__ import annotations

from service.stores.base import (
    Cells,
    Grid,
    PlanRecord,
    Store,
    decode_map,
    encode_map,
    pack,
    unpack,
)
from service.stores.memory import MemoryStore
from service.stores.redis import RedisStore

__all__ = [
    "Cells",
    "Grid",
    "MemoryStore",
    "PlanRecord",
    "RedisStore",
    "Store",
    "decode_map",
    "encode_map",
    "open_store",
    "pack",
    "unpack",
]


def open_store(
    url: str,
    *,
    ttl_seconds: float,
    map_bytes: int | None = None,
    map_ttl_seconds: float = 0,
    shares: int = 1,
    max_plans: int | None = None,
) -> Store:
    """The store that ``PLANNER_STORE_URL`` names: ``memory://`` (its maps bounded by
    ``map_bytes``, each of ``shares`` tenants to an equal share) or a Redis URL (its maps
    expiring ``map_ttl_seconds`` after their last use; 0: kept). Each tenant holds at most
    ``max_plans`` live plans (None: any number)."""
    if url.startswith("memory://"):
        return MemoryStore(
            ttl_seconds=ttl_seconds, max_map_bytes=map_bytes, shares=shares, max_plans=max_plans
        )
    return RedisStore(
        url, ttl_seconds=ttl_seconds, map_ttl_seconds=map_ttl_seconds, max_plans=max_plans
    )

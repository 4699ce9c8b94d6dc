"""Where maps and plans live, chosen by ``PLANNER_STORE_URL``'s scheme in :func:`open_store`.

Store (``base``)            the interface and the formats every store keeps
├── MemoryStore (``memory``)  this process only: ``memory://``
└── RedisStore  (``redis``)   shared by replicas: ``redis://``, ``rediss://``, ``unix://``
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


def open_store(url: str, *, ttl_seconds: float) -> Store:
    """The store that ``PLANNER_STORE_URL`` names: ``memory://`` or a Redis URL."""
    if url.startswith("memory://"):
        return MemoryStore(ttl_seconds=ttl_seconds)
    return RedisStore(url, ttl_seconds=ttl_seconds)

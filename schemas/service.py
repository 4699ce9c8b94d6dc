"""The service's own state: ``GET /healthz``."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["CacheStats", "HealthPublic", "StoreHealth"]

EXAMPLE_CACHE: dict[str, Any] = {
    "entries": 2,
    "bytes": 26214400,
    "max_bytes": 536870912,
    "hits": 5,
    "misses": 2,
    "evictions": 0,
}


class CacheStats(BaseModel):
    """The analysis and wave cache."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_CACHE]})

    entries: int = Field(ge=0)
    bytes: int = Field(ge=0)
    max_bytes: int = Field(ge=0)
    hits: int = Field(ge=0)
    misses: int = Field(ge=0, description="Entries computed.")
    evictions: int = Field(ge=0)


EXAMPLE_STORE_DOWN: dict[str, Any] = {
    "kind": "redis",
    "up": False,
    "detail": "store unavailable; retry later",
}


class StoreHealth(BaseModel):
    """Whether the store of maps and plans answers."""

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"kind": "redis", "up": True}, EXAMPLE_STORE_DOWN]}
    )

    kind: Literal["memory", "redis"] = Field(description="`PLANNER_STORE_URL`'s kind of store.")
    up: bool
    detail: str | None = Field(default=None, description="Why the store does not answer.")


class HealthPublic(BaseModel):
    """The service answers; `ok` (200) when its store does too, else `unavailable` (503)."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {"status": "ok", "store": {"kind": "memory", "up": True}, "cache": EXAMPLE_CACHE},
                {"status": "unavailable", "store": EXAMPLE_STORE_DOWN, "cache": EXAMPLE_CACHE},
            ]
        }
    )

    status: Literal["ok", "unavailable"] = "ok"
    store: StoreHealth
    cache: CacheStats

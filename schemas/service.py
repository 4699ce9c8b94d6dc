"""The service's own state: ``GET /healthz``."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["CacheStats", "HealthPublic"]

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


class HealthPublic(BaseModel):
    """The service is up and answering."""

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"status": "ok", "cache": EXAMPLE_CACHE}]}
    )

    status: Literal["ok"] = "ok"
    cache: CacheStats

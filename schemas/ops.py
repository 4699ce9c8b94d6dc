"""Liveness and readiness: ``GET /healthz`` and ``GET /readyz``."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from schemas.service import EXAMPLE_CACHE, EXAMPLE_STORE_DOWN, CacheStats, StoreHealth

__all__ = ["LivePublic", "PoolStats", "ReadyPublic"]


class LivePublic(BaseModel):
    """The process is up and its event loop answers."""

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"status": "ok", "uptime_seconds": 12.5}]}
    )

    status: Literal["ok"] = "ok"
    uptime_seconds: float = Field(ge=0, description="Since the service started serving.")


EXAMPLE_POOL: dict[str, Any] = {"size": 2, "busy": 1, "queued": 0, "warm": True}


class PoolStats(BaseModel):
    """The worker pool running planner kernels."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_POOL]})

    size: int = Field(ge=1, description="Worker threads (`PLANNER_POOL_SIZE`).")
    busy: int = Field(ge=0, description="Calls running now.")
    queued: int = Field(ge=0, description="Calls waiting for a worker.")
    warm: bool = Field(
        description="Whether every kernel is compiled (false while the rest compile in the "
        "background after `PLANNER_WARMUP_WAIT_SECONDS`)."
    )


class ReadyPublic(BaseModel):
    """`ok` (200) when the store answers and the warm-up is done or had its time, else
    `unavailable` (503)."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "status": "ok",
                    "store": {"kind": "memory", "up": True},
                    "pool": EXAMPLE_POOL,
                    "cache": EXAMPLE_CACHE,
                },
                {
                    "status": "unavailable",
                    "store": EXAMPLE_STORE_DOWN,
                    "pool": EXAMPLE_POOL,
                    "cache": EXAMPLE_CACHE,
                },
            ]
        }
    )

    status: Literal["ok", "unavailable"]
    store: StoreHealth
    pool: PoolStats
    cache: CacheStats

"""The service's settings: one class, read once from ``PLANNER_*`` environment variables."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, SecretStr, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict
from redis.asyncio.connection import parse_url

from service.cgroup import available_cpus

__all__ = ["Settings"]

MIB = 1024 * 1024


class Settings(BaseSettings):
    """Every knob of the service; a bad value stops the service at start."""

    model_config = SettingsConfigDict(env_prefix="PLANNER_", frozen=True)

    store_url: str = Field(
        default="memory://",
        description="Where maps and plans live: `memory://` (this process) or a Redis URL, "
        "`redis://host:port/db` (shared by replicas; `rediss://` for TLS).",
    )
    max_map_cells: int = Field(default=4096 * 4096, ge=1, description="Largest map, in cells.")
    max_json_map_cells: int = Field(
        default=2048 * 1024,
        ge=1,
        description="Largest map sent as JSON numbers (`grid`, `occupancy_grid`), in cells: "
        "parsing them holds the event loop (about 0.1 s a million cells); larger maps come as "
        "`rows` or as an image with its YAML.",
    )
    max_body_bytes: int = Field(
        default=32 * MIB,
        ge=1024,
        description="Largest map upload (`POST /maps`), refused before parsing.",
    )
    max_dynamic_obstacles: int = Field(
        default=10_000, ge=0, description="Most dynamic obstacles in one step or simulation."
    )
    obstacle_persistence_seconds: float = Field(
        default=5.0,
        gt=0,
        le=86400,
        description="How long a cell a scan marked stays in the map's live layer unless a "
        "later ray clears it.",
    )
    cache_bytes: int = Field(
        default=512 * MIB, ge=0, description="Bound of the analysis and wave cache."
    )
    plan_ttl_seconds: float = Field(
        default=3600.0, gt=0, description="A plan untouched this long is forgotten."
    )
    fleet_lease_seconds: float = Field(
        default=30.0,
        gt=0,
        description="A fleet robot that has not stepped this long is taken as standing where it "
        "last was: the fleet is solved again around it (it rejoins when it steps again).",
    )
    fleet_solve_seconds: float = Field(
        default=2.0,
        gt=0,
        le=60,
        description="The time budget of one solve of a fleet's joint plan (MAPF); a solve that "
        "fails within it keeps the previous plan.",
    )
    max_fleet_robots: int = Field(
        default=500, ge=1, description="Most robots (live plans) in one fleet."
    )
    pool_size: int = Field(
        default_factory=available_cpus,
        ge=1,
        description="Worker threads running planner kernels (default: the CPUs this process "
        "may use, the cgroup's CPU quota when there is one).",
    )
    host: str = Field(default="127.0.0.1", description="Address `python -m service` listens on.")
    port: int = Field(default=8000, ge=1, le=65535, description="Port `python -m service` uses.")
    log_level: Literal["debug", "info", "warning", "error"] = Field(
        default="info", description="JSON log lines at this level and above, on stdout."
    )
    warmup_wait_seconds: float = Field(
        default=8.0,
        ge=0,
        description="At start, how long readiness waits for the kernels to compile (or load from "
        "numba's cache); the rest compiles in the background, a request needing one first "
        "waiting for it.",
    )
    step_pool_size: int = Field(
        default=2, ge=1, description="Worker threads reserved for steps that replan."
    )
    max_queued_jobs: int = Field(
        default=64, ge=0, description="Heavy jobs waiting for a worker at most (503 beyond)."
    )
    map_store_bytes: int = Field(
        default=2048 * MIB, ge=1024, description="Bound of the maps kept by the memory store."
    )
    map_ttl_seconds: float = Field(
        default=7 * 24 * 3600.0, ge=0, description="A map unused this long leaves Redis (0: kept)."
    )
    request_timeout_seconds: float = Field(
        default=30.0, gt=0, description="A request running longer is stopped with 504."
    )
    body_timeout_seconds: float = Field(
        default=30.0, gt=0, description="A body not arrived in this time gets 408."
    )
    max_step_body_bytes: int = Field(
        default=MIB,
        ge=1024,
        description="Largest body of any request but a map upload: a step, a plan, a simulation "
        "(413 beyond).",
    )
    max_simulation_steps: int = Field(
        default=200_000, ge=1, description="Largest `max_steps` of a simulation (422 beyond)."
    )
    http_parser: Literal["h11", "httptools"] = Field(
        default="h11",
        description="uvicorn's HTTP/1.1 parser: `h11` holds a request's head to "
        "`PLANNER_MAX_HEADER_BYTES` (400 beyond); `httptools` is faster on small requests but "
        "holds heads of any size: only behind a proxy that bounds them (docker/nginx.conf).",
    )
    max_header_bytes: int = Field(
        default=16384, ge=1024, description="Largest request head (line and headers), with h11."
    )
    keep_alive_seconds: int = Field(
        default=5, ge=1, description="An idle keep-alive connection is closed after this long."
    )
    max_connections: int = Field(
        default=16384,
        ge=16,
        description="Open connections at most; beyond, uvicorn answers every request 503 at once "
        "(`/healthz` too: keep it above what the clients and the proxy open). The process's "
        "open-file limit is raised to fit it when the hard limit allows.",
    )
    max_requests: int = Field(
        default=1024,
        ge=1,
        description="Requests in progress at most (bodies, work, event streams); beyond, 503 "
        "`BUSY` with `Retry-After: 1`. `/healthz` and `/readyz` are never refused.",
    )
    max_plans_per_tenant: int = Field(
        default=10_000,
        ge=1,
        description="Live plans one API key (or the open service) may hold in the store at "
        "once (429 `TOO_MANY_PLANS` beyond).",
    )
    max_streams_per_tenant: int = Field(
        default=20,
        ge=1,
        description="Event streams (`/plan/{plan_id}/events`) one API key may hold open on one "
        "replica (503 `TOO_MANY_STREAMS` beyond).",
    )
    stream_queue_bytes: int = Field(
        default=4 * MIB,
        ge=1024,
        description="Bytes of step events waiting for one event stream's reader at most; a "
        "reader further behind is dropped (its stream ends with `event: dropped`).",
    )
    api_keys: SecretStr = Field(
        default=SecretStr(""),
        description="Comma-separated API keys; empty: the service is open.",
    )

    @property
    def keys(self) -> list[str]:
        """The API keys, without blanks."""
        return [k.strip() for k in self.api_keys.get_secret_value().split(",") if k.strip()]

    @field_validator("store_url")
    @classmethod
    def _known_store(cls, url: str) -> str:
        if url.startswith("memory://"):
            return url
        if not url.startswith(("redis://", "rediss://", "unix://")):
            scheme = url.partition("://")[0][:20]
            msg = f"store_url must be memory:// or redis://host:port/db; got scheme {scheme!r}"
            raise ValueError(msg)
        try:
            parse_url(url)
        except ValueError as exc:
            # The URL may hold a password: it is not repeated.
            raise ValueError(f"store_url is not a valid Redis URL: {exc}") from None
        return url

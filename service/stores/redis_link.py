"""What the parts of the Redis store share (docs/redis-store.md): one redis-py client, its
settings (the plans' and maps' TTLs, the tenants' cap of plans) and the one place where
redis-py's errors become the service's (:class:`StoreUnavailable`, :class:`InsufficientStorage`)."""

from __future__ import annotations

import logging
import time

from redis import exceptions as rx
from redis.asyncio import Redis
from redis.asyncio.retry import Retry
from redis.backoff import NoBackoff

from service.errors import InsufficientStorage, StoreUnavailable

__all__ = ["SOCKET_TIMEOUT", "UNAVAILABLE", "Reaching", "RedisLink"]

log = logging.getLogger("service.store")

SOCKET_TIMEOUT = 2.0
"""Seconds to connect to Redis or wait for an answer before a request answers 503."""
UNAVAILABLE = "store unavailable; retry later"
"""What a client is told when Redis cannot answer (the reason goes to the log)."""


class RedisLink:
    """The client (connections made on demand, one immediate retry: a call resent after a lost
    answer finds its own versioned write), its address for the log, and the store's settings."""

    def __init__(
        self, url: str, *, ttl_seconds: float, map_ttl_seconds: float, max_plans: int | None
    ) -> None:
        self.redis = Redis.from_url(
            url,
            socket_timeout=SOCKET_TIMEOUT,
            socket_connect_timeout=SOCKET_TIMEOUT,
            retry=Retry(NoBackoff(), 1),
        )
        kw = self.redis.connection_pool.connection_kwargs
        # For the log only: never the password, never in an answer.
        self.address = kw.get("path") or f"{kw.get('host', 'localhost')}:{kw.get('port', 6379)}"
        self.reaching = Reaching(self.address)
        self.ttl_ms = max(1, round(ttl_seconds * 1000))
        self.map_ttl_ms = max(0, round(map_ttl_seconds * 1000))
        self.max_plans = max_plans or 0

    async def get(self, key: str) -> bytes | None:
        with self.reaching:
            value = await self.redis.get(key)
        assert value is None or isinstance(value, bytes)  # no decode_responses
        return value

    def until(self) -> float:
        """When a plan written now expires (its robot's ``until`` in its fleet)."""
        return time.time() + self.ttl_ms / 1000


class Reaching:
    """A ``with`` block in which the client's "Redis cannot answer" errors become
    StoreUnavailable (and "out of memory" InsufficientStorage); the reason is logged, the
    client told nothing more."""

    __slots__ = ("address",)

    def __init__(self, address: str) -> None:
        self.address = address

    def __enter__(self) -> None:
        return None

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, trace: object
    ) -> None:
        if isinstance(exc, rx.ConnectionError | rx.TimeoutError):
            log.warning("redis at %s %s", self.address, _why(exc))
            raise StoreUnavailable(UNAVAILABLE) from exc
        if isinstance(exc, rx.ResponseError):
            if str(exc).startswith("OOM"):
                log.warning("redis at %s is at its maxmemory: %s", self.address, exc)
                msg = "the store is full (Redis maxmemory); retry when plans or maps expire"
                raise InsufficientStorage(msg) from exc
            log.warning("redis at %s refused a command: %s", self.address, exc)
            raise StoreUnavailable(UNAVAILABLE) from exc


def _why(exc: rx.RedisError) -> str:
    if isinstance(exc, rx.BusyLoadingError):
        return "is loading its data"
    if isinstance(exc, rx.TimeoutError):
        return f"did not answer within {SOCKET_TIMEOUT:g} s"
    cause = exc.__cause__ or exc.__context__
    if isinstance(cause, ConnectionRefusedError):
        return "refused the connection"
    return f"cannot be reached ({type(cause or exc).__name__})"

"""Steps as events for the live viewer: each step is published on its plan's channel and
``GET /plan/{plan_id}/events`` streams it as server-sent events. The bus lives in this process
(:class:`MemoryBus`) or in Redis pub/sub (:class:`RedisBus`), so every replica's steps are heard."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from abc import ABC, abstractmethod
from typing import Annotated, Any, cast

import orjson
from fastapi import Depends, Request
from redis import exceptions as rx
from redis.asyncio import Redis
from redis.asyncio.client import PubSub

from service.errors import StoreUnavailable

__all__ = [
    "HEARTBEAT",
    "BusDep",
    "EventBus",
    "MemoryBus",
    "RedisBus",
    "Subscription",
    "channel",
    "get_bus",
    "open_bus",
]

HEARTBEAT = 15.0
"""Seconds between the keep-alive comments of an idle stream (proxies close silent ones)."""

Event = dict[str, Any]


def channel(plan_id: str) -> str:
    """The plan's Redis pub/sub channel (which a Redis store's step write also publishes on)."""
    return f"planner:events:{plan_id}"


Queue = asyncio.Queue[Event]
_LOG = logging.getLogger("service.viewer.events")


class Subscription(ABC):
    """One stream's subscription to a plan's events, open from creation until :meth:`close`."""

    @abstractmethod
    async def next(self) -> Event | None:
        """The next event; None after ``HEARTBEAT`` seconds without one. Raises ``EOFError``
        when the bus can no longer deliver (Redis gone)."""

    @abstractmethod
    async def close(self) -> None:
        """Unsubscribe (idempotent)."""


class EventBus(ABC):
    """Publish a plan's events; subscribe to them."""

    @abstractmethod
    async def publish(self, plan_id: str, event: Event) -> None:
        """Send ``event`` to the plan's current subscribers (never raises)."""

    @abstractmethod
    async def subscribe(self, plan_id: str) -> Subscription:
        """A subscription to the plan's events from now on."""

    def listening(self, plan_id: str) -> bool:
        """Whether an event of the plan may reach anyone (else the caller need not build it)."""
        return True

    async def close(self) -> None:  # noqa: B027 - a bus with nothing to release keeps this
        """Release connections."""


class MemoryBus(EventBus):
    """Subscribers' queues in this process."""

    def __init__(self) -> None:
        self._queues: dict[str, set[asyncio.Queue[Event]]] = {}

    async def publish(self, plan_id: str, event: Event) -> None:
        for queue in self._queues.get(plan_id, ()):
            queue.put_nowait(event)

    def listening(self, plan_id: str) -> bool:
        return plan_id in self._queues

    async def subscribe(self, plan_id: str) -> Subscription:
        queue: asyncio.Queue[Event] = asyncio.Queue()
        self._queues.setdefault(plan_id, set()).add(queue)
        return _MemorySubscription(self._queues, plan_id, queue)


class _MemorySubscription(Subscription):
    def __init__(
        self,
        queues: dict[str, set[asyncio.Queue[Event]]],
        plan_id: str,
        queue: asyncio.Queue[Event],
    ) -> None:
        self._queues, self._plan_id, self._queue = queues, plan_id, queue

    async def next(self) -> Event | None:
        try:
            return await asyncio.wait_for(self._queue.get(), HEARTBEAT)
        except TimeoutError:
            return None

    async def close(self) -> None:
        queues = self._queues.get(self._plan_id, set())
        queues.discard(self._queue)
        if not queues:
            self._queues.pop(self._plan_id, None)


class RedisBus(EventBus):
    """Redis pub/sub: every replica publishes, a stream on any replica hears them all."""

    def __init__(self, url: str) -> None:
        # No socket timeout: a subscription waits for messages for as long as it is open.
        self._redis = Redis.from_url(url, socket_connect_timeout=2.0)

    async def publish(self, plan_id: str, event: Event) -> None:
        try:
            await self._redis.publish(channel(plan_id), orjson.dumps(event))
        except rx.RedisError as exc:
            _LOG.warning("step event not published", extra={"fields": {"reason": str(exc)}})

    async def subscribe(self, plan_id: str) -> Subscription:
        pubsub = self._redis.pubsub(ignore_subscribe_messages=True)
        try:
            await pubsub.subscribe(channel(plan_id))
        except rx.RedisError as exc:
            await pubsub.aclose()  # type: ignore[no-untyped-call]
            raise StoreUnavailable(f"store unavailable: {exc}; retry later") from exc
        return _RedisSubscription(pubsub)

    async def close(self) -> None:
        await self._redis.aclose()


class _RedisSubscription(Subscription):
    def __init__(self, pubsub: PubSub) -> None:
        self._pubsub = pubsub
        self._closed = False

    async def next(self) -> Event | None:
        try:
            message = await self._pubsub.get_message(timeout=HEARTBEAT)
        except rx.RedisError as exc:
            raise EOFError(str(exc)) from exc
        if message is None or message["type"] != "message":
            return None
        return cast(Event, orjson.loads(message["data"]))

    async def close(self) -> None:
        if not self._closed:
            self._closed = True
            with contextlib.suppress(rx.RedisError):
                await self._pubsub.aclose()  # type: ignore[no-untyped-call]


def open_bus(store_url: str) -> EventBus:
    """The bus beside the store ``PLANNER_STORE_URL`` names: Redis pub/sub with Redis."""
    if store_url.startswith("memory://"):
        return MemoryBus()
    return RedisBus(store_url)


async def get_bus(request: Request) -> EventBus:
    return cast(EventBus, request.app.state.bus)


BusDep = Annotated[EventBus, Depends(get_bus)]

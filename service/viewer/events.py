"""Steps as events for the live viewer: each step is published on its plan's channel and
``GET /plan/{plan_id}/events`` streams it as server-sent events. The bus lives in this process
(:class:`MemoryBus`) or in Redis pub/sub (:class:`RedisBus`), so every replica's steps are heard.

Either way the streams open in this process are held by one :class:`Hub`: each stream's events
wait in a queue of its own, bounded in bytes (a reader that falls further behind is dropped: its
stream ends with an ``event: dropped``), and each tenant may hold a bounded number of streams.
With Redis, one pub/sub connection a process carries every plan's channel to its streams.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable
from typing import Annotated, cast

from fastapi import Depends, Request
from redis import exceptions as rx
from redis.asyncio import Redis
from redis.asyncio.client import PubSub
from redis.asyncio.retry import Retry
from redis.backoff import NoBackoff

from service.errors import StoreUnavailable, TooManyStreams
from service.tenants import TENANT

__all__ = [
    "DROPPED",
    "HEARTBEAT",
    "BusDep",
    "Dropped",
    "EventBus",
    "Hub",
    "MemoryBus",
    "RedisBus",
    "Subscription",
    "channel",
    "get_bus",
    "open_bus",
]

HEARTBEAT = 15.0
"""Seconds between the keep-alive comments of an idle stream (proxies close silent ones)."""
DROPPED = "TOO_SLOW"
"""The ``code`` of the ``dropped`` event that ends a stream whose reader fell too far behind."""
SUBSCRIBE_TIMEOUT = 2.0
"""Seconds Redis has to confirm a new channel's subscription before the stream answers 503."""
UNAVAILABLE = "store unavailable; retry later"
"""What a client is told when Redis cannot answer (the reason goes to the log)."""

_PREFIX = "planner:events:"
_LOG = logging.getLogger("service.viewer.events")


def channel(plan_id: str) -> str:
    """The plan's Redis pub/sub channel (which a Redis store's step write also publishes on)."""
    return _PREFIX + plan_id


class Dropped(Exception):
    """The stream's reader fell more than the hub's ``max_bytes`` behind: its events were
    dropped, and so is the stream."""


class Subscription(ABC):
    """One stream's subscription to a plan's events, open from creation until :meth:`close`."""

    @abstractmethod
    async def next(self) -> bytes | None:
        """The next event (JSON); None after ``HEARTBEAT`` seconds without one. Raises
        ``EOFError`` when the bus can no longer deliver (Redis gone), :class:`Dropped` when
        this stream's reader fell too far behind."""

    @abstractmethod
    async def close(self) -> None:
        """Unsubscribe (idempotent)."""


class Hub:
    """The event streams open in this process: each plan's inboxes, and each tenant's count of
    streams (at most ``max_streams``: :class:`TooManyStreams` beyond). An inbox holds at most
    ``max_bytes`` of events not yet read (an event larger than that alone): an event that does
    not fit drops the inbox, its queued events freed at once."""

    def __init__(self, *, max_bytes: int, max_streams: int) -> None:
        self.max_bytes, self.max_streams = max_bytes, max_streams
        self._inboxes: dict[str, set[_Inbox]] = {}
        self._streams: dict[str, int] = {}  # open streams per tenant
        self.on_empty: Callable[[str], None] | None = None
        """Called with a plan's id when its last inbox leaves (the Redis bus unsubscribes)."""

    def open(self, plan_id: str) -> _Inbox:
        tenant = TENANT.get()
        held = self._streams.get(tenant, 0)
        if held >= self.max_streams:
            msg = (
                f"this key has {held} event streams open on this replica "
                f"(PLANNER_MAX_STREAMS_PER_TENANT); close one and retry"
            )
            raise TooManyStreams(msg)
        self._streams[tenant] = held + 1
        inbox = _Inbox(self, plan_id, tenant)
        self._inboxes.setdefault(plan_id, set()).add(inbox)
        return inbox

    def listening(self, plan_id: str) -> bool:
        return plan_id in self._inboxes

    def streams(self, tenant: str) -> int:
        """The tenant's streams open now (for tests)."""
        return self._streams.get(tenant, 0)

    def deliver(self, plan_id: str, data: bytes) -> None:
        """Queue ``data`` for each of the plan's inboxes; drop those it does not fit in."""
        for inbox in list(self._inboxes.get(plan_id, ())):
            if not inbox.offer(data, self.max_bytes):
                _LOG.warning(
                    "event stream dropped: its reader is too slow",
                    extra={"fields": {"plan_id": plan_id[:64], "queued": inbox.queued}},
                )
                inbox.fail(Dropped())
                self.leave(inbox)

    def fail_all(self, plan_ids: set[str]) -> None:
        """End every stream of those plans with ``EOFError`` (their bus is gone)."""
        for plan_id in plan_ids:
            for inbox in list(self._inboxes.get(plan_id, ())):
                inbox.fail(EOFError())
                self.leave(inbox)

    def leave(self, inbox: _Inbox) -> None:
        """The inbox hears no more events (idempotent)."""
        inboxes = self._inboxes.get(inbox.plan_id)
        if inboxes is None or inbox not in inboxes:
            return
        inboxes.discard(inbox)
        if not inboxes:
            del self._inboxes[inbox.plan_id]
            if self.on_empty is not None:
                self.on_empty(inbox.plan_id)

    def release(self, inbox: _Inbox) -> None:
        """The inbox's stream has ended: its tenant may open another."""
        self.leave(inbox)
        left = self._streams.get(inbox.tenant, 1) - 1
        if left:
            self._streams[inbox.tenant] = left
        else:
            self._streams.pop(inbox.tenant, None)


class _Inbox(Subscription):
    """A stream's queue of events (on the event loop: no locks)."""

    def __init__(self, hub: Hub, plan_id: str, tenant: str) -> None:
        self.plan_id, self.tenant = plan_id, tenant
        self._hub = hub
        self._events: deque[bytes] = deque()
        self.queued = 0  # bytes in _events
        self._error: BaseException | None = None
        self._ready = asyncio.Event()
        self._closed = False

    def offer(self, data: bytes, limit: int) -> bool:
        if self._events and self.queued + len(data) > limit:
            return False
        self._events.append(data)
        self.queued += len(data)
        self._ready.set()
        return True

    def fail(self, error: BaseException) -> None:
        self._events.clear()
        self.queued = 0
        self._error = error
        self._ready.set()

    async def next(self) -> bytes | None:
        if not self._events and self._error is None:
            self._ready.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._ready.wait(), HEARTBEAT)
        if self._error is not None:
            raise self._error
        if not self._events:
            return None
        data = self._events.popleft()
        self.queued -= len(data)
        return data

    async def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._events.clear()
            self._hub.release(self)


class EventBus(ABC):
    """Publish a plan's events; subscribe to them."""

    def __init__(self, hub: Hub) -> None:
        self.hub = hub

    in_store = False
    """Whether a store that publishes (``Store.publishes``) reaches this bus's subscribers:
    then a step's event goes out with the step's write, in its round trip."""

    @abstractmethod
    async def publish(self, plan_id: str, event: bytes) -> None:
        """Send ``event`` (JSON) to the plan's current subscribers (never raises)."""

    @abstractmethod
    async def subscribe(self, plan_id: str) -> Subscription:
        """A subscription to the plan's events from now on; :class:`TooManyStreams` when the
        tenant has its ``max_streams`` open here."""

    def listening(self, plan_id: str) -> bool:
        """Whether an event of the plan may reach anyone (else the caller need not build it)."""
        return True

    async def close(self) -> None:  # noqa: B027 - a bus with nothing to release keeps this
        """Release connections."""


class MemoryBus(EventBus):
    """Subscribers' queues in this process."""

    async def publish(self, plan_id: str, event: bytes) -> None:
        self.hub.deliver(plan_id, event)

    def listening(self, plan_id: str) -> bool:
        return self.hub.listening(plan_id)

    async def subscribe(self, plan_id: str) -> Subscription:
        return self.hub.open(plan_id)


class RedisBus(EventBus):
    """Redis pub/sub: every replica publishes, a stream on any replica hears them all. One
    pub/sub connection carries every channel this process's streams listen to (subscribed
    when a plan's first stream opens, unsubscribed when its last closes), and one task reads
    it into the hub: a stream takes no connection of its own."""

    in_store = True

    def __init__(self, url: str, hub: Hub) -> None:
        super().__init__(hub)
        # No socket timeout: the pub/sub connection waits for messages as long as it is open.
        # No retry: a connection lost ends the streams (browsers reconnect by themselves).
        self._redis = Redis.from_url(url, socket_connect_timeout=2.0, retry=Retry(NoBackoff(), 0))
        self._pubsub: PubSub | None = None
        self._reader: asyncio.Task[None] | None = None
        self._connecting = asyncio.Lock()  # streams opening together share one connection
        self._confirmed: dict[str, asyncio.Future[None]] = {}  # channels subscribed (or asked)
        hub.on_empty = self._unsubscribe

    async def publish(self, plan_id: str, event: bytes) -> None:
        try:
            await self._redis.publish(channel(plan_id), event)
        except rx.RedisError as exc:
            _LOG.warning("step event not published", extra={"fields": {"reason": str(exc)}})

    async def subscribe(self, plan_id: str) -> Subscription:
        inbox = self.hub.open(plan_id)  # the tenant's cap first: no Redis work beyond it
        try:
            name = channel(plan_id)
            confirmed = self._confirmed.get(name)
            if confirmed is None:
                confirmed = self._confirmed[name] = asyncio.get_running_loop().create_future()
                try:
                    pubsub = await self._connected()
                    await pubsub.subscribe(name)
                except BaseException:
                    _settle(confirmed, EOFError())  # for the streams waiting on it too
                    raise
            await asyncio.wait_for(asyncio.shield(confirmed), SUBSCRIBE_TIMEOUT)
        except (rx.RedisError, OSError, TimeoutError, EOFError) as exc:
            await inbox.close()
            _LOG.warning("event stream not subscribed", extra={"fields": {"reason": _why(exc)}})
            raise StoreUnavailable(UNAVAILABLE) from exc
        except BaseException:
            await inbox.close()
            raise
        return inbox

    async def _connected(self) -> PubSub:
        """The process's pub/sub connection, and the task reading it (started once, also when
        streams open together)."""
        async with self._connecting:
            if self._pubsub is None:
                self._pubsub = self._redis.pubsub()
            pubsub = self._pubsub
            if self._reader is None:
                try:
                    await pubsub.connect()  # type: ignore[no-untyped-call]
                except BaseException:
                    self._pubsub = None  # the next stream starts afresh
                    raise
                self._reader = asyncio.get_running_loop().create_task(self._read(pubsub))
            return pubsub

    async def _read(self, pubsub: PubSub) -> None:
        try:
            while True:
                message = await pubsub.get_message(timeout=None)
                if message is None:
                    continue
                name = message["channel"].decode()
                if message["type"] == "message":
                    self.hub.deliver(name[len(_PREFIX) :], message["data"])
                elif message["type"] == "subscribe":
                    confirmed = self._confirmed.get(name)
                    if confirmed is not None and not confirmed.done():
                        confirmed.set_result(None)
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # Redis gone: every stream ends, the next one reconnects
            _LOG.warning("event bus lost its connection", extra={"fields": {"reason": _why(exc)}})
            lost = {name[len(_PREFIX) :] for name in self._confirmed}
            for confirmed in self._confirmed.values():
                _settle(confirmed, EOFError())
            self._confirmed, self._pubsub, self._reader = {}, None, None
            self.hub.fail_all(lost)
            with contextlib.suppress(Exception):
                await pubsub.aclose()  # type: ignore[no-untyped-call]

    def _unsubscribe(self, plan_id: str) -> None:
        name = channel(plan_id)
        confirmed = self._confirmed.pop(name, None)
        if confirmed is None or self._pubsub is None:
            return
        if confirmed.done() and confirmed.exception() is not None:
            return  # never subscribed: an UNSUBSCRIBE sent later could undo the next SUBSCRIBE
        task = asyncio.get_running_loop().create_task(self._send_unsubscribe(self._pubsub, name))
        _PENDING.add(task)
        task.add_done_callback(_PENDING.discard)

    async def _send_unsubscribe(self, pubsub: PubSub, name: str) -> None:
        if name in self._confirmed:  # a new stream of the plan came meanwhile: still wanted
            return
        with contextlib.suppress(rx.RedisError, OSError):
            await pubsub.unsubscribe(name)

    async def close(self) -> None:
        if self._reader is not None:
            self._reader.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._reader
        if self._pubsub is not None:
            with contextlib.suppress(rx.RedisError, OSError):
                await self._pubsub.aclose()  # type: ignore[no-untyped-call]
        await self._redis.aclose()


def _settle(future: asyncio.Future[None], error: BaseException) -> None:
    """Fail ``future`` unless settled (its error marked retrieved: no stream may wait on it)."""
    if not future.done():
        future.set_exception(error)
        future.exception()


_PENDING: set[asyncio.Task[None]] = set()
"""Unsubscriptions being sent (held: a task only weakly referenced may vanish)."""


def _why(exc: BaseException) -> str:
    """Why Redis did not answer, for the log (never for a client)."""
    if isinstance(exc, TimeoutError):
        return f"no confirmation within {SUBSCRIBE_TIMEOUT:g} s"
    return f"{type(exc).__name__}: {exc}"[:200]


def open_bus(store_url: str, *, max_bytes: int, max_streams: int) -> EventBus:
    """The bus beside the store ``PLANNER_STORE_URL`` names (Redis pub/sub with Redis), its
    streams' queues bounded by ``max_bytes`` and ``max_streams`` a tenant."""
    hub = Hub(max_bytes=max_bytes, max_streams=max_streams)
    if store_url.startswith("memory://"):
        return MemoryBus(hub)
    return RedisBus(store_url, hub)


async def get_bus(request: Request) -> EventBus:
    return cast(EventBus, request.app.state.bus)


BusDep = Annotated[EventBus, Depends(get_bus)]

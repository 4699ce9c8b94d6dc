"""The service's one ASGI middleware, in front of the app: what every request meets before any
route, and what it leaves behind.

In turn: its request id (``X-Request-ID``, echoed on the answer); a place among the requests in
progress (503 beyond ``PLANNER_MAX_REQUESTS``; ``/healthz`` and ``/readyz`` always answered);
its API key (401 without one, before the body is read); its body, read whole and bounded (413
over the limit, by its ``Content-Length`` or as it streams in; 408 when it has not all come in
time); the app, under the request timeout (504), a heavy request's work cancelled when its
client goes away; then its metrics and its log line, labelled by its route template (the route
the router would give a request refused before it). One wrapper of ``send`` sees the answer's
status and adds the id.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from collections.abc import Sequence

from starlette.routing import BaseRoute
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.edge.auth import ApiKeys
from service.edge.cancel import CANCEL
from service.edge.limits import Limits, is_heavy
from service.errors import Busy, ServiceError, send_problem
from service.ops.logs import REQUEST_ID
from service.ops.metrics import Metrics
from service.ops.observe import HEADER, Recorder, request_id_of, route_of
from service.tenants import TENANT

__all__ = ["Edge"]

log = logging.getLogger("service.requests")

PROBES = frozenset({"/healthz", "/readyz"})
"""Paths never refused for want of a place: a probe must tell a busy process from a dead one."""


class _Answer:
    """The request's ``send``: notes the answer's status (0 until it starts) and adds the
    request id to its headers."""

    __slots__ = ("request_id", "send", "status")

    def __init__(self, send: Send, request_id: bytes) -> None:
        self.send = send
        self.request_id = request_id
        self.status = 0

    async def __call__(self, message: Message) -> None:
        if message["type"] == "http.response.start":
            self.status = message["status"]
            message["headers"] = [*message.get("headers", ()), (HEADER, self.request_id)]
        await self.send(message)


class Edge:
    """Pure ASGI middleware: request id, API key, body limits, deadline, metrics and log line.

    ``routes`` are the API's (its routers'), to label the requests refused before routing.
    """

    def __init__(
        self,
        app: ASGIApp,
        *,
        metrics: Metrics,
        routes: Sequence[BaseRoute],
        keys: list[str],
        max_bytes: int,
        max_step_bytes: int | None = None,
        body_timeout: float = 30.0,
        request_timeout: float = 30.0,
        max_requests: int | None = None,
    ) -> None:
        self.app = app
        self.max_requests = max_requests
        self.requests = 0
        """Requests in progress now (probes not counted)."""
        self.routes = routes
        self.recorder = Recorder(metrics)
        self.keys = ApiKeys(keys)
        self.limits = Limits(
            max_bytes=max_bytes,
            max_step_bytes=max_step_bytes,
            body_timeout=body_timeout,
            request_timeout=request_timeout,
        )

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        began = time.perf_counter()
        answer = _Answer(send, request_id_of(scope))
        token = REQUEST_ID.set(answer.request_id.decode())
        counted = scope["path"] not in PROBES
        try:
            if counted and self.max_requests is not None and self.requests >= self.max_requests:
                msg = (
                    f"the service is busy: {self.requests} requests are in progress "
                    f"(PLANNER_MAX_REQUESTS is {self.max_requests}); retry later"
                )
                await send_problem(scope, answer, Busy(msg))
                return
            self.requests += counted
            try:
                await self._serve(scope, receive, answer)
            finally:
                self.requests -= counted
        finally:
            route = route_of(scope, self.routes)
            self.recorder.record(scope, route, answer.status or 500, began, answer.request_id)
            REQUEST_ID.reset(token)

    async def _serve(self, scope: Scope, receive: Receive, send: _Answer) -> None:
        try:
            tenant = self.keys.admit(scope)
            body = await self.limits.read(scope, receive)
        except ServiceError as error:
            await send_problem(scope, send, error)
            return
        if body is None:  # the client went away
            return
        token = TENANT.set(tenant)
        try:
            if is_heavy(scope):
                await self._watched(scope, receive, send, body)
            else:
                await self._timed(scope, receive, send, body)
        finally:
            TENANT.reset(token)

    async def _timed(self, scope: Scope, receive: Receive, send: _Answer, body: bytes) -> None:
        """A light request (a step, a read): run here, under the request timeout."""
        chunks: list[Message] = [{"type": "http.request", "body": body, "more_body": False}]

        async def replay() -> Message:
            return chunks.pop() if chunks else await receive()

        with self.limits.deadline() as expired:
            await self.app(scope, replay, send)
        if expired and not send.status:
            await send_problem(scope, send, self.limits.timed_out())

    async def _watched(self, scope: Scope, receive: Receive, send: _Answer, body: bytes) -> None:
        """A heavy request: run as a task, stopped when its client goes away or time runs out;
        its cancel flag (:mod:`service.edge.cancel`) set then, for the work in a worker."""
        chunks: list[Message] = [{"type": "http.request", "body": body, "more_body": False}]
        gone = asyncio.Event()
        flag = threading.Event()

        async def replay() -> Message:
            if chunks:
                return chunks.pop()
            await gone.wait()
            return {"type": "http.disconnect"}

        async def watch() -> None:
            while (await receive())["type"] != "http.disconnect":
                await asyncio.sleep(0.05)  # not expected once the body is in; never spin
            gone.set()

        cancel = CANCEL.set(flag)
        try:
            work = asyncio.ensure_future(self.app(scope, replay, send))
            watcher = asyncio.ensure_future(watch())
        finally:
            CANCEL.reset(cancel)  # the task keeps its copy of the context
        try:
            done, _ = await asyncio.wait(
                {work, watcher},
                timeout=self.limits.request_timeout,
                return_when=asyncio.FIRST_COMPLETED,
            )
        finally:
            watcher.cancel()
        if work in done:
            work.result()  # the app's own errors propagate as they would without this
            return
        flag.set()
        work.cancel()
        with contextlib.suppress(asyncio.CancelledError, Exception):
            await work
        if watcher in done and gone.is_set():
            log.warning("client gone: %s %s cancelled", scope["method"], scope["path"][:100])
            return
        if not send.status:
            await send_problem(scope, send, self.limits.timed_out())

"""Pure ASGI middleware around every request: its ``X-Request-ID``, its metrics and its one
JSON log line (``service.ops.logs``).

The request id is the client's ``X-Request-ID`` when it is a plain token (letters, digits,
``._:-``, at most 128), else a new random one; the answer carries it back, whatever its status.
"""

from __future__ import annotations

import logging
import random
import re
import time

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.ops.logs import ACCESS, REQUEST_ID, REQUEST_LINES
from service.ops.metrics import UNMATCHED, Metrics

__all__ = ["HEADER", "Observe", "request_id_of", "route_of"]

HEADER = b"x-request-id"
_TOKEN = re.compile(rb"[A-Za-z0-9._:\-]{1,128}")


class Observe:
    """Times the request, labels it by its route template, counts it, logs it."""

    def __init__(self, app: ASGIApp, *, metrics: Metrics) -> None:
        self.app = app
        self.metrics = metrics

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        began = time.perf_counter()
        request_id = request_id_of(scope)
        status = 500  # unless an answer starts

        async def send_with_id(message: Message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = message["status"]
                message["headers"] = [*message.get("headers", ()), (HEADER, request_id)]
            await send(message)

        token = REQUEST_ID.set(request_id.decode())
        try:
            await self.app(scope, receive, send_with_id)
        finally:
            self.record(scope, status, began, request_id)
            REQUEST_ID.reset(token)

    def record(self, scope: Scope, status: int, began: float, request_id: bytes) -> None:
        """Count and log a request answered with ``status`` (500 when no answer started)
        that began at ``began`` (``time.perf_counter()``)."""
        seconds = time.perf_counter() - began
        route = route_of(scope)
        self.metrics.observe(scope["method"], route, status, seconds)
        if ACCESS.isEnabledFor(logging.INFO):
            REQUEST_LINES.write(
                {
                    "request_id": request_id.decode(),
                    "method": scope["method"],
                    "route": route,
                    "status": status,
                    "duration_ms": round(seconds * 1000, 3),
                }
            )


def route_of(scope: Scope) -> str:
    """The template of the route that served the request (``/plan/{plan_id}/step``), which the
    router leaves in the scope, or :data:`UNMATCHED`."""
    path = getattr(scope.get("route"), "path", None)
    return path if isinstance(path, str) and path else UNMATCHED


def request_id_of(scope: Scope) -> bytes:
    """The request's ``X-Request-ID`` when it is a plain token, else a new random one."""
    for name, value in scope["headers"]:
        if name == HEADER and _TOKEN.fullmatch(value):
            return bytes(value)
    return b"%032x" % random.getrandbits(128)  # as a UUID4's hex but cheaper (not a secret)

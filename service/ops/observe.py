"""What every request leaves behind: its ``X-Request-ID``, its metrics and its one JSON log line
(``service.ops.logs``); the edge middleware (:mod:`service.edge.middleware`) calls these.

The request id is the client's ``X-Request-ID`` when it is a plain token (letters, digits,
``._:-``, at most 128), else a new random one; the answer carries it back, whatever its status.
"""

from __future__ import annotations

import logging
import random
import re
import time
from collections.abc import Sequence

from starlette.routing import BaseRoute, Match
from starlette.types import Scope

from service.ops.logs import ACCESS, REQUEST_LINES
from service.ops.metrics import UNMATCHED, Metrics

__all__ = ["HEADER", "Recorder", "request_id_of", "route_of"]

HEADER = b"x-request-id"
_TOKEN = re.compile(rb"[A-Za-z0-9._:\-]{1,128}")


class Recorder:
    """Counts a request in ``metrics`` under its route template, and logs its line."""

    def __init__(self, metrics: Metrics) -> None:
        self.metrics = metrics

    def record(
        self, scope: Scope, route: str, status: int, began: float, request_id: bytes
    ) -> None:
        """Count and log a request answered with ``status`` (500 when no answer started)
        that began at ``began`` (``time.perf_counter()``)."""
        seconds = time.perf_counter() - began
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


def route_of(scope: Scope, routes: Sequence[BaseRoute] = ()) -> str:
    """The template of the route that served the request (``/plan/{plan_id}/step``), which the
    router leaves in the scope; for a request refused before routing, that of the route of
    ``routes`` the router would give it (a full match first, as the router matches); else
    :data:`UNMATCHED`."""
    route = scope.get("route")
    if route is None and routes:
        matches = [(r.matches(scope)[0], r) for r in routes]
        route = next((r for m, r in matches if m is Match.FULL), None) or next(
            (r for m, r in matches if m is Match.PARTIAL), None
        )
    path = getattr(route, "path", None)
    return path if isinstance(path, str) and path else UNMATCHED


def request_id_of(scope: Scope) -> bytes:
    """The request's ``X-Request-ID`` when it is a plain token, else a new random one."""
    for name, value in scope["headers"]:
        if name == HEADER and _TOKEN.fullmatch(value):
            return bytes(value)
    return b"%032x" % random.getrandbits(128)  # as a UUID4's hex but cheaper (not a secret)

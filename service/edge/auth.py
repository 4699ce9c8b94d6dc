"""API keys: with ``PLANNER_API_KEYS`` set, every request but the open paths carries one.

A key comes as ``Authorization: Bearer <key>`` or ``X-API-Key: <key>``; it is compared with
each configured key in constant time (:func:`hmac.compare_digest`), and the request then acts
for that key's tenant (:mod:`service.edge.tenants`). A request without a known key is refused with
401 before its body is read.
"""

from __future__ import annotations

import hmac

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.edge.tenants import TENANT, tenant_of
from service.errors import Unauthorized, problem

__all__ = ["OPEN_PATHS", "ApiKeys"]

OPEN_PATHS = frozenset(
    {"/healthz", "/readyz", "/metrics", "/docs", "/docs/oauth2-redirect", "/redoc", "/openapi.json"}
)
"""Paths served without a key: probes, metrics and the API's documentation."""


class ApiKeys:
    """ASGI middleware: the request's key, checked, becomes its tenant."""

    def __init__(self, app: ASGIApp, *, keys: list[str]) -> None:
        self.app = app
        self._keys = [(k.encode(), tenant_of(k)) for k in keys]

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not self._keys or scope["path"] in OPEN_PATHS:
            await self.app(scope, receive, send)
            return
        tenant = self._tenant(_presented(scope))
        if tenant is None:
            error = Unauthorized(
                "an API key is required: send Authorization: Bearer <key> or X-API-Key: <key>",
                field="authorization",
            )
            response = problem(error.status, error.message, field=error.field, code=error.code)

            async def nothing() -> Message:
                return {"type": "http.disconnect"}

            await response(scope, nothing, send)
            return
        token = TENANT.set(tenant)
        try:
            await self.app(scope, receive, send)
        finally:
            TENANT.reset(token)

    def _tenant(self, presented: bytes | None) -> str | None:
        if presented is None:
            return None
        found = None
        for key, tenant in self._keys:  # every key compared: the time says nothing of which
            if hmac.compare_digest(presented, key):
                found = tenant
        return found


def _presented(scope: Scope) -> bytes | None:
    for name, value in scope["headers"]:
        if name == b"x-api-key":
            return bytes(value.strip())
        if name == b"authorization":
            scheme, _, credentials = bytes(value).partition(b" ")
            if scheme.lower() == b"bearer" and credentials.strip():
                return credentials.strip()
    return None

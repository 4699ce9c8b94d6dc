"""API keys: with ``PLANNER_API_KEYS`` set, a request (but for the open paths) carries one as
``Authorization: Bearer`` or ``X-API-Key``, compared in constant time, and acts for that key's
tenant."""

from __future__ import annotations

import hmac

from starlette.types import Scope

from service.errors import Unauthorized
from service.tenants import tenant_of

__all__ = ["OPEN_PATHS", "OPEN_PREFIX", "ApiKeys"]

OPEN_PATHS = frozenset(
    {"/healthz", "/readyz", "/metrics", "/docs", "/docs/oauth2-redirect", "/redoc", "/openapi.json"}
)
"""Paths served without a key: probes, metrics and the API's documentation."""
OPEN_PREFIX = "/docs/static/"
"""The documentation's scripts, styles and icon (:mod:`service.ops.docs`), open as its pages
are: without them ``/docs`` is a blank page."""


class ApiKeys:
    """The configured keys (none: every request is let in, as the tenant ``""``)."""

    def __init__(self, keys: list[str]) -> None:
        self._keys = [(k.encode(), tenant_of(k)) for k in keys]

    def admit(self, scope: Scope) -> str:
        """The tenant the request acts for (``""`` without keys, and on an open path);
        :class:`Unauthorized` when it carries no configured key."""
        path = scope["path"]
        if not self._keys or path in OPEN_PATHS or path.startswith(OPEN_PREFIX):
            return ""
        presented = _presented(scope)
        found = None
        if presented is not None:
            for key, tenant in self._keys:  # every key compared: the time says nothing of which
                if hmac.compare_digest(presented, key):
                    found = tenant
        if found is None:
            raise Unauthorized(
                "an API key is required: send Authorization: Bearer <key> or X-API-Key: <key>",
                field="authorization",
            )
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

"""Who a request acts for: the tenant of its API key, a context variable the stores read to keep
each tenant's maps and plans (and cache share) apart; without keys, one tenant ``""``."""

from __future__ import annotations

import hashlib
from contextvars import ContextVar

__all__ = ["TENANT", "scoped", "tenant_of"]

TENANT: ContextVar[str] = ContextVar("planner_tenant", default="")
"""The tenant of the request being served (``""``: no keys configured)."""


def tenant_of(key: str) -> str:
    """A key's tenant: 16 hex digits of its SHA-256, so that stores never hold the key."""
    return hashlib.sha256(key.encode()).hexdigest()[:16]


def scoped(ident: str) -> str:
    """``ident`` as the store keeps it for the current tenant."""
    tenant = TENANT.get()
    return f"{tenant}.{ident}" if tenant else ident

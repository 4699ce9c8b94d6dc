"""How the Redis store writes its values and keys: a version before a record's JSON, and the
key of a tenant's set of live plans (shared by the plan and fleet halves of the store)."""

from __future__ import annotations

from service.tenants import TENANT

__all__ = ["plans_of", "split"]


def plans_of() -> str:
    """The key of the current tenant's set of live plans (scored by their expiry, in ms)."""
    return f"planner:plans-of:{TENANT.get()}"


def split(value: bytes) -> tuple[int, bytes]:
    """A stored plan's version and record (0 for a record written before versions)."""
    if value[:1] == b"{":
        return 0, value
    version, _, json = value.partition(b" ")
    return int(version), json

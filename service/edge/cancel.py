"""The current request's cancel flag, set when its client goes away or its time runs out: long
work in a worker thread polls it, so the worker is freed soon after nobody waits."""

from __future__ import annotations

import threading
from contextvars import ContextVar

__all__ = ["CANCEL", "cancelled"]

CANCEL: ContextVar[threading.Event | None] = ContextVar("planner_cancel", default=None)
"""Set by :class:`service.edge.middleware.Edge` for each heavy request."""


def cancelled() -> threading.Event:
    """The current request's flag (a fresh one, never set, outside a request)."""
    flag = CANCEL.get()
    return flag if flag is not None else threading.Event()

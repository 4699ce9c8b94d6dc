"""The current request's cancel flag: set when its client goes away or its time runs out.

Work that runs long in a worker thread (a simulation's episode) polls it between bounded chunks
and stops, so that the worker is free again soon after nobody waits for its answer.
"""

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

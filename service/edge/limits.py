"""A request's bounds: its body's size (413) and arrival time (408), and its run time (504).

The edge middleware (:mod:`service.edge.middleware`) applies them; the settings are
``PLANNER_MAX_BODY_BYTES`` (a map upload), ``PLANNER_MAX_STEP_BODY_BYTES`` (any other body: a
step, a plan, a simulation), ``PLANNER_BODY_TIMEOUT_SECONDS`` and
``PLANNER_REQUEST_TIMEOUT_SECONDS``.
"""

from __future__ import annotations

import asyncio
import logging
import re
from asyncio import Task

from starlette.types import Receive, Scope

from service.errors import BodyTimeout, TimedOut, TooLarge

__all__ = ["Deadline", "Deadlines", "Limits", "is_heavy", "is_map_upload"]

log = logging.getLogger("service.requests")
_ZONES = re.compile(r"/maps/[^/]+/zones")


def is_map_upload(scope: Scope) -> bool:
    """A map upload, ``POST /maps``, or a keepout mask, ``POST /maps/{map_id}/zones``: the
    bodies that may be megabytes."""
    path = str(scope["path"]).rstrip("/")
    return scope["method"] == "POST" and (path == "/maps" or _ZONES.fullmatch(path) is not None)


def is_heavy(scope: Scope) -> bool:
    """A request whose work may run long (an upload, a plan, a render, a simulation)."""
    path = str(scope["path"])
    return (scope["method"] == "POST" and not path.endswith("/step")) or path.endswith(".png")


class Limits:
    """A request's bounds: its body's size and arrival time, and its run time."""

    def __init__(
        self,
        *,
        max_bytes: int,
        max_step_bytes: int | None = None,
        body_timeout: float = 30.0,
        request_timeout: float = 30.0,
    ) -> None:
        self.max_bytes = max_bytes
        self.max_step_bytes = max_step_bytes if max_step_bytes is not None else max_bytes
        self.body_timeout = body_timeout
        self.request_timeout = request_timeout
        self._deadlines = Deadlines()

    async def read(self, scope: Scope, receive: Receive) -> bytes | None:
        """The whole body now, bounded in bytes (a map upload's by ``max_bytes``, any other by
        ``max_step_bytes``) and in time (nothing downstream waits on a
        trickling client): :class:`TooLarge` over the limit, by its ``Content-Length`` or once
        that much has arrived, :class:`BodyTimeout` when it has not all come in time, ``None``
        when the client went away (logged)."""
        limit, setting = (
            (self.max_bytes, "PLANNER_MAX_BODY_BYTES")
            if is_map_upload(scope)
            else (self.max_step_bytes, "PLANNER_MAX_STEP_BODY_BYTES")
        )
        for name, length in scope["headers"]:
            if name == b"content-length":
                size = int(length) if length.isdigit() and len(length) < 20 else 0
                if size > limit:
                    raise _too_large(f"{size} bytes", setting, limit)
                break
        chunks: list[bytes] = []
        total = 0
        with self._deadlines.until(self.body_timeout) as expired:
            while True:
                message = await receive()
                if message["type"] == "http.disconnect":
                    log.warning(
                        "client gone during its request %s %s after %d body bytes",
                        scope["method"], scope["path"][:100], total,
                    )  # fmt: skip
                    return None
                chunk = message.get("body", b"")
                chunks.append(chunk)
                total += len(chunk)
                if total > limit:
                    raise _too_large(f"more than {limit} bytes", setting, limit)
                if not message.get("more_body", False):
                    return chunks[0] if len(chunks) == 1 else b"".join(chunks)
        assert expired
        msg = (
            f"the request body did not arrive within {self.body_timeout:g} s "
            f"(PLANNER_BODY_TIMEOUT_SECONDS; {total} bytes came)"
        )
        raise BodyTimeout(msg, field="body")

    def deadline(self) -> Deadline:
        """``PLANNER_REQUEST_TIMEOUT_SECONDS`` for a light request (a step, a read) run in this
        task: see :meth:`Deadlines.until` (answer :meth:`timed_out` when it expired)."""
        return self._deadlines.until(self.request_timeout)

    def timed_out(self) -> TimedOut:
        """The error of a request stopped by its timeout."""
        msg = (
            f"the request ran over {self.request_timeout:g} s (PLANNER_REQUEST_TIMEOUT_SECONDS) "
            "and was stopped; try a smaller map, fewer steps or a smaller picture"
        )
        return TimedOut(msg)


class Deadlines:
    """Tasks to cancel when their deadline passes, checked every ``tick`` seconds by one task
    on the server's event loop: a request costs a dict entry rather than a timer of its own
    (``asyncio.timeout``), and a deadline is kept to within ``tick``."""

    def __init__(self, tick: float = 0.1) -> None:
        self.tick = tick
        self._due: dict[Task[object], tuple[float, list[bool]]] = {}
        self._reaper: Task[None] | None = None

    def until(self, seconds: float) -> Deadline:
        """A ``with`` block cancelled after ``seconds`` unless it ends first (the task running
        it is cancelled, and the block ends there without raising): the list it yields is true
        (``[True]``) once that happened. The loop is the reaper's while that runs (asking
        asyncio for the running loop costs a system call)."""
        reaper = self._reaper
        if reaper is None or reaper.done() or not reaper.get_loop().is_running():
            reaper = self._reaper = asyncio.get_running_loop().create_task(self._reap())
        loop = reaper.get_loop()
        task = asyncio.current_task(loop)
        assert task is not None
        return Deadline(self._due, task, loop.time() + seconds)

    async def _reap(self) -> None:
        loop = asyncio.get_running_loop()
        while True:
            await asyncio.sleep(self.tick)
            now = loop.time()
            for task, (due, expired) in list(self._due.items()):
                if due <= now:
                    del self._due[task]
                    expired.append(True)
                    task.cancel()


class Deadline:
    """A task's entry in :class:`Deadlines` for the length of a ``with`` block (a class, not a
    generator: it is entered twice a request)."""

    __slots__ = ("_due", "_entry", "_task")

    def __init__(
        self, due: dict[Task[object], tuple[float, list[bool]]], task: Task[object], at: float
    ) -> None:
        expired: list[bool] = []
        self._due, self._task, self._entry = due, task, (at, expired)

    def __enter__(self) -> list[bool]:
        self._due[self._task] = self._entry
        return self._entry[1]

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: object
    ) -> bool:
        self._due.pop(self._task, None)
        if kind is asyncio.CancelledError and self._entry[1]:  # our cancel, not another's
            self._task.uncancel()
            return True
        return False


def _too_large(size: str, setting: str, limit: int) -> TooLarge:
    return TooLarge(f"the request body has {size}; {setting} is {limit}", field="body")

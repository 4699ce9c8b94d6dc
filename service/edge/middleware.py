"""Bounds every request in size and time, before and while the app serves it.

- The body: refused (413) over ``PLANNER_MAX_BODY_BYTES`` (``PLANNER_MAX_STEP_BODY_BYTES`` for a
  step) by its ``Content-Length`` or while it streams in, and 408 (the connection closed) when it
  has not all arrived within ``PLANNER_BODY_TIMEOUT_SECONDS``; a client gone mid-upload is one
  line in the log.
- The work: a request running over ``PLANNER_REQUEST_TIMEOUT_SECONDS`` is stopped with 504, and
  the work of a heavy request (an upload, a plan, a render, a simulation) whose client went away
  is cancelled; both set the request's cancel flag (:mod:`service.edge.cancel`), which long
  computations poll.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
from asyncio import Task

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.edge.cancel import CANCEL
from service.errors import BodyTimeout, ServiceError, TimedOut, TooLarge, problem

__all__ = ["BodyLimit"]

log = logging.getLogger("service.requests")


def _is_step(scope: Scope) -> bool:
    return scope["method"] == "POST" and str(scope["path"]).endswith("/step")


def _is_heavy(scope: Scope) -> bool:
    path = str(scope["path"])
    return (scope["method"] == "POST" and not path.endswith("/step")) or path.endswith(".png")


class BodyLimit:
    """ASGI middleware bounding each request's body (size and arrival time) and run time."""

    def __init__(
        self,
        app: ASGIApp,
        *,
        max_bytes: int,
        max_step_bytes: int | None = None,
        body_timeout: float = 30.0,
        request_timeout: float = 30.0,
    ) -> None:
        self.app = app
        self.max_bytes = max_bytes
        self.max_step_bytes = max_step_bytes if max_step_bytes is not None else max_bytes
        self.body_timeout = body_timeout
        self.request_timeout = request_timeout
        self._deadlines = Deadlines()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        step = _is_step(scope)
        limit, setting = (
            (self.max_step_bytes, "PLANNER_MAX_STEP_BODY_BYTES")
            if step
            else (self.max_bytes, "PLANNER_MAX_BODY_BYTES")
        )
        length = dict(scope["headers"]).get(b"content-length")
        if length is not None:
            size = int(length) if length.isdigit() and len(length) < 20 else 0
            if size > limit:
                await _answer(scope, send, _too_large(f"{size} bytes", setting, limit))
                return
        # The whole body now, bounded in bytes and in time: nothing downstream waits on a
        # trickling client, and a body over the limit is refused once that much has arrived.
        chunks: list[Message] = []
        total = 0
        task = asyncio.current_task()
        assert task is not None
        with self._deadlines.until(task, self.body_timeout) as expired:
            try:
                while True:
                    message = await receive()
                    if message["type"] == "http.disconnect":
                        log.warning(
                            "client gone during its request %s %s after %d body bytes",
                            scope["method"], scope["path"][:100], total,
                        )  # fmt: skip
                        return
                    chunks.append(message)
                    total += len(message.get("body", b""))
                    if total > limit:
                        await _answer(
                            scope, send, _too_large(f"more than {limit} bytes", setting, limit)
                        )
                        return
                    if not message.get("more_body", False):
                        break
            except asyncio.CancelledError:
                if not expired:
                    raise
                task.uncancel()
                msg = (
                    f"the request body did not arrive within {self.body_timeout:g} s "
                    f"(PLANNER_BODY_TIMEOUT_SECONDS; {total} bytes came)"
                )
                await _answer(scope, send, BodyTimeout(msg, field="body"))
                return
        if _is_heavy(scope):
            flag = threading.Event()
            token = CANCEL.set(flag)
            try:
                await self._watched(scope, receive, send, chunks, flag)
            finally:
                CANCEL.reset(token)
        else:
            await self._timed(scope, receive, send, chunks, task)

    async def _timed(
        self, scope: Scope, receive: Receive, send: Send, chunks: list[Message], task: Task[object]
    ) -> None:
        """A light request (a step, a read): run here, under the request timeout."""
        started = False

        async def replay() -> Message:
            return chunks.pop(0) if chunks else await receive()

        async def sending(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        with self._deadlines.until(task, self.request_timeout) as expired:
            try:
                await self.app(scope, replay, sending)
            except asyncio.CancelledError:
                if not expired:
                    raise
                task.uncancel()
                if not started:
                    await _answer(scope, send, self._timed_out())

    async def _watched(
        self,
        scope: Scope,
        receive: Receive,
        send: Send,
        chunks: list[Message],
        flag: threading.Event,
    ) -> None:
        """A heavy request: run as a task, stopped when its client goes away or time runs out."""
        started = False
        gone = asyncio.Event()

        async def replay() -> Message:
            if chunks:
                return chunks.pop(0)
            await gone.wait()
            return {"type": "http.disconnect"}

        async def sending(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        async def watch() -> None:
            while (await receive())["type"] != "http.disconnect":
                await asyncio.sleep(0.05)  # not expected once the body is in; never spin
            gone.set()

        work = asyncio.ensure_future(self.app(scope, replay, sending))
        watcher = asyncio.ensure_future(watch())
        try:
            done, _ = await asyncio.wait(
                {work, watcher}, timeout=self.request_timeout, return_when=asyncio.FIRST_COMPLETED
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
        if not started:
            await _answer(scope, send, self._timed_out())

    def _timed_out(self) -> TimedOut:
        msg = (
            f"the request ran over {self.request_timeout:g} s (PLANNER_REQUEST_TIMEOUT_SECONDS) "
            "and was stopped; try a smaller map, fewer steps or a smaller picture"
        )
        return TimedOut(msg)


class Deadlines:
    """Tasks to cancel when their deadline passes, checked every ``tick`` seconds by one task.

    Cheaper per request than ``asyncio.timeout`` (a timer scheduled and cancelled each time, and
    ~25 us on a busy host, measured): here a request costs a dict entry, and a deadline is kept
    to within ``tick``.
    """

    def __init__(self, tick: float = 0.1) -> None:
        self.tick = tick
        self._due: dict[Task[object], tuple[float, list[bool]]] = {}
        self._reaper: Task[None] | None = None

    def until(self, task: Task[object], seconds: float) -> _Deadline:
        """Cancel ``task`` after ``seconds`` unless the block ends first; the list it yields
        is true (``[True]``) once that happened."""
        loop = asyncio.get_running_loop()
        if self._reaper is None or self._reaper.done():
            self._reaper = loop.create_task(self._reap())
        return _Deadline(self._due, task, loop.time() + seconds)

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


class _Deadline:
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

    def __exit__(self, *exc: object) -> None:
        self._due.pop(self._task, None)


def _too_large(size: str, setting: str, limit: int) -> TooLarge:
    return TooLarge(f"the request body has {size}; {setting} is {limit}", field="body")


async def _answer(scope: Scope, send: Send, error: ServiceError) -> None:
    response = problem(error.status, error.message, field=error.field, code=error.code)

    async def nothing() -> Message:
        return {"type": "http.disconnect"}

    await response(scope, nothing, send)

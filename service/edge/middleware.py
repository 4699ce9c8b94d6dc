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
from service.errors import BodyTimeout, ServiceError, TimedOut, TooLarge, send_problem

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
        try:
            body = await self.read(scope, receive)
        except ServiceError as error:
            await send_problem(scope, send, error)
            return
        if body is None:
            return
        chunks: list[Message] = [{"type": "http.request", "body": body, "more_body": False}]
        if _is_heavy(scope):
            flag = threading.Event()
            token = CANCEL.set(flag)
            try:
                await self._watched(scope, receive, send, chunks, flag)
            finally:
                CANCEL.reset(token)
        else:
            await self._timed(scope, receive, send, chunks)

    async def read(self, scope: Scope, receive: Receive) -> bytes | None:
        """The whole body now, bounded in bytes and in time (nothing downstream waits on a
        trickling client): :class:`TooLarge` over the limit, by its ``Content-Length`` or once
        that much has arrived, :class:`BodyTimeout` when it has not all come in time, ``None``
        when the client went away (logged)."""
        limit, setting = (
            (self.max_step_bytes, "PLANNER_MAX_STEP_BODY_BYTES")
            if _is_step(scope)
            else (self.max_bytes, "PLANNER_MAX_BODY_BYTES")
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

    def deadline(self) -> _Deadline:
        """``PLANNER_REQUEST_TIMEOUT_SECONDS`` for a light request (a step, a read) run in this
        task: see :meth:`Deadlines.until` (answer :meth:`timed_out` when it expired)."""
        return self._deadlines.until(self.request_timeout)

    async def _timed(
        self, scope: Scope, receive: Receive, send: Send, chunks: list[Message]
    ) -> None:
        """A light request (a step, a read): run here, under the request timeout."""
        started = False

        async def replay() -> Message:
            return chunks.pop(0) if chunks else await receive()

        async def sending(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        with self.deadline() as expired:
            await self.app(scope, replay, sending)
        if expired and not started:
            await send_problem(scope, send, self.timed_out())

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
            await send_problem(scope, send, self.timed_out())

    def timed_out(self) -> TimedOut:
        """The error of a request stopped by its timeout."""
        msg = (
            f"the request ran over {self.request_timeout:g} s (PLANNER_REQUEST_TIMEOUT_SECONDS) "
            "and was stopped; try a smaller map, fewer steps or a smaller picture"
        )
        return TimedOut(msg)


class Deadlines:
    """Tasks to cancel when their deadline passes, checked every ``tick`` seconds by one task
    (on the one event loop that runs at a time, the server's).

    Cheaper per request than ``asyncio.timeout`` (a timer scheduled and cancelled each time, and
    ~25 us on a busy host, measured): here a request costs a dict entry, and a deadline is kept
    to within ``tick``.
    """

    def __init__(self, tick: float = 0.1) -> None:
        self.tick = tick
        self._due: dict[Task[object], tuple[float, list[bool]]] = {}
        self._reaper: Task[None] | None = None

    def until(self, seconds: float) -> _Deadline:
        """A ``with`` block cancelled after ``seconds`` unless it ends first (the task running
        it is cancelled, and the block ends there without raising): the list it yields is true
        (``[True]``) once that happened. The loop is the reaper's while that runs: asking
        asyncio for the running loop costs a ``getpid`` system call each time (CPython checks
        for a fork), which a step on a virtual machine feels."""
        reaper = self._reaper
        if reaper is None or reaper.done() or not reaper.get_loop().is_running():
            reaper = self._reaper = asyncio.get_running_loop().create_task(self._reap())
        loop = reaper.get_loop()
        task = asyncio.current_task(loop)
        assert task is not None
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

"""Refuses request bodies over the size limit before any of them is parsed."""

from __future__ import annotations

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.errors import TooLarge, problem

__all__ = ["BodyLimit"]


class BodyLimit:
    """ASGI middleware: a body over ``max_bytes`` gets a 413, by its ``Content-Length`` when it
    has one, else by counting the chunks as they arrive (buffering at most ``max_bytes``)."""

    def __init__(self, app: ASGIApp, *, max_bytes: int) -> None:
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope["headers"])
        length = headers.get(b"content-length")
        if length is not None:
            size = int(length) if length.isdigit() else 0
            if size > self.max_bytes:
                await self._refuse(scope, receive, send, f"{size} bytes")
                return
            await self.app(scope, receive, send)
            return
        chunks: list[Message] = []
        total = 0
        while True:
            message = await receive()
            chunks.append(message)
            total += len(message.get("body", b""))
            if total > self.max_bytes:
                await self._refuse(scope, receive, send, f"more than {self.max_bytes} bytes")
                return
            if message["type"] != "http.request" or not message.get("more_body", False):
                break

        async def replay() -> Message:
            return chunks.pop(0) if chunks else await receive()

        await self.app(scope, replay, send)

    async def _refuse(self, scope: Scope, receive: Receive, send: Send, size: str) -> None:
        error = TooLarge(
            f"the request body has {size}; PLANNER_MAX_BODY_BYTES is {self.max_bytes}",
            field="body",
        )
        response = problem(413, error.message, field=error.field, code=error.code)
        await response(scope, receive, send)

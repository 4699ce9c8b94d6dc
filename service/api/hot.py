"""The hot path: a route served without the framework's per-request machinery.

A step is the request a fleet sends many times a second, and FastAPI's machinery around an
endpoint (exception and exit-stack middlewares, route matching over every route, dependency
solving, the request-response wrapper) costs more than the memory store's whole step. A
:class:`HotRoute` is declared like any route (``/docs`` documents it from its signature), and
:class:`HotPath`, the innermost middleware, serves requests that match one straight from there:
the same handler, the same errors (the app's exception handlers), the same answers. Any other
request, or a hot route's path with another method, goes on to the router as usual.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine, Iterable, Mapping
from typing import Any, cast

import orjson
from fastapi import Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute, APIRouter
from pydantic import BaseModel, ValidationError
from starlette.types import ASGIApp, Receive, Scope, Send

from service.api.deps import check_query
from service.edge.guards import check_depth

__all__ = ["HotPath", "HotRoute"]

Handler = Callable[[Request], Coroutine[Any, Any, Response]]
ExceptionHandler = Callable[[Request, Any], Any]
"""An exception handler as Starlette keeps them (``app.exception_handlers``)."""


class HotRoute(APIRoute):
    """A route whose endpoint takes its path parameters (strings), one body model and the
    ``Request``, and gets them without dependency solving. The body is read as FastAPI reads a
    JSON body model, with the same errors: 422 for a body that is missing, not JSON, not
    declared ``application/json``, nested too deep (:func:`~service.edge.guards.check_depth`)
    or invalid (errors located under ``body``), and for any query parameter."""

    def get_route_handler(self) -> Handler:
        bodies = self.dependant.body_params
        assert len(bodies) == 1, "one body model"
        assert not self.dependant.dependencies, "no dependencies"
        assert not self.dependant.query_params, "no query parameters"
        assert not self.dependant.header_params, "no header parameters"
        model = cast(type[BaseModel], bodies[0].field_info.annotation)
        name = bodies[0].name
        endpoint = cast(Callable[..., Coroutine[Any, Any, Response]], self.endpoint)

        async def handler(request: Request) -> Response:
            if request.scope.get("query_string"):
                check_query(request, frozenset())
            raw = await request.body()
            try:
                body = model.model_validate(_json_body(raw, request.headers.get("content-type")))
            except ValidationError as exc:
                errors = [{**e, "loc": ("body", *e["loc"])} for e in exc.errors(include_url=False)]
                raise RequestValidationError(errors) from None
            return await endpoint(**request.path_params, **{name: body}, request=request)

        return handler


class HotPath:
    """ASGI middleware serving the ``POST`` :class:`HotRoute` routes of ``routers`` (included
    in the app without a prefix) directly; errors go to the app's exception ``handlers`` (the
    ones ``service.errors.install`` registers)."""

    def __init__(
        self,
        app: ASGIApp,
        *,
        routers: Iterable[APIRouter],
        handlers: Mapping[Any, ExceptionHandler],
    ) -> None:
        self.app = app
        self._hot = [
            (route, route.get_route_handler())
            for router in routers
            for route in router.routes
            if isinstance(route, HotRoute) and route.methods == {"POST"}
        ]
        self._handlers = handlers

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope["method"] == "POST":
            for route, handler in self._hot:
                match = route.path_regex.match(scope["path"])
                if match is not None:
                    scope["route"] = route  # what the router leaves for metrics and logs
                    scope["endpoint"] = route.endpoint
                    scope["path_params"] = match.groupdict()
                    await self._serve(handler, Request(scope, receive), send)
                    return
        await self.app(scope, receive, send)

    async def _serve(self, handler: Handler, request: Request, send: Send) -> None:
        try:
            response = await handler(request)
        except Exception as exc:
            answer = self._handler_for(exc)
            if answer is None:
                raise
            response = cast(Response, await answer(request, exc))
        await response(request.scope, request.receive, send)

    def _handler_for(self, exc: Exception) -> ExceptionHandler | None:
        for kind in type(exc).__mro__:
            if kind in self._handlers:
                return self._handlers[kind]
        return None


def _json_body(raw: bytes, content_type: str | None) -> Any:
    """What FastAPI validates a JSON body model against: the parsed JSON, or the bytes
    themselves when the body is not declared JSON (the model refuses them)."""
    if not raw:
        raise RequestValidationError(
            [{"type": "missing", "loc": ("body",), "msg": "Field required", "input": None}]
        )
    check_depth(raw)  # whatever it is declared to be, as for every other POST body
    media = (content_type or "").partition(";")[0].strip().lower()
    if media != "application/json" and not (
        media.startswith("application/") and media.endswith("+json")
    ):
        return raw
    try:
        return orjson.loads(raw)
    except orjson.JSONDecodeError as exc:
        error = {
            "type": "json_invalid",
            "loc": ("body", exc.pos),
            "msg": "JSON decode error",
            "input": {},
            "ctx": {"error": exc.msg},
        }
        raise RequestValidationError([error]) from None

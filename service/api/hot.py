"""The hot path: a route served without the framework's per-request machinery.

A step is the request a fleet sends many times a second, and the machinery around an endpoint
(a middleware's closures and wrapped ``send``, exception and exit-stack middlewares, route
matching over every route, dependency solving, the request-response wrapper) costs more than the
memory store's whole step. A :class:`HotRoute` is declared like any route (``/docs`` documents it
from its signature), and :class:`HotPath`, the outermost of the service's middlewares (to which
:class:`HotApp`, the app, hands such a request at once), serves requests that match one in one
function: what :class:`~service.ops.observe.Observe`, :class:`~service.edge.auth.ApiKeys` and
:class:`~service.edge.middleware.BodyLimit` do to every request, done by their own methods in
turn, then the same handler, the same errors (the app's exception handlers), the same answers.
Any other request, or a hot route's path with another method, goes on through the middlewares
to the router as usual.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Coroutine, Iterable, Mapping
from typing import Any, TypeVar, cast

import orjson
from fastapi import FastAPI, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute, APIRouter
from pydantic import BaseModel, ValidationError
from starlette.types import ASGIApp, Receive, Scope, Send

from service.api.deps import check_query
from service.edge.auth import ApiKeys
from service.edge.guards import check_depth
from service.edge.middleware import BodyLimit
from service.edge.tenants import TENANT
from service.ops.logs import REQUEST_ID
from service.ops.observe import HEADER, Observe, request_id_of

__all__ = ["HotApp", "HotPath", "HotRoute", "JSONBytes"]

Handler = Callable[[Request], Coroutine[Any, Any, Response]]
ExceptionHandler = Callable[[Request, Any], Any]
"""An exception handler as Starlette keeps them (``app.exception_handlers``)."""
Middleware = TypeVar("Middleware")


class HotRoute(APIRoute):
    """A route whose endpoint takes its path parameters (strings), one body model and the
    ``Request``, gets them without dependency solving, and answers with a plain ``Response``.
    The body is read as FastAPI reads a JSON body model, with the same errors: 422 for a body
    that is missing, not JSON, not declared ``application/json``, nested too deep
    (:func:`~service.edge.guards.check_depth`) or invalid (errors located under ``body``), and
    for any query parameter."""

    def get_route_handler(self) -> Handler:
        bodies = self.dependant.body_params
        assert len(bodies) == 1, "one body model"
        assert not self.dependant.dependencies, "no dependencies"
        assert not self.dependant.query_params, "no query parameters"
        assert not self.dependant.header_params, "no header parameters"
        self._model = cast(type[BaseModel], bodies[0].field_info.annotation)
        self._name = bodies[0].name
        self._endpoint = cast(Callable[..., Coroutine[Any, Any, Response]], self.endpoint)

        async def handler(request: Request) -> Response:  # served by the router
            return await self.answer(request, await request.body())

        return handler

    async def answer(self, request: Request, raw: bytes) -> Response:
        """The endpoint's answer to the request whose whole body is ``raw``."""
        if request.scope.get("query_string"):
            check_query(request, frozenset())
        try:
            body = self._model.model_validate(_json_body(raw, _content_type(request.scope)))
        except ValidationError as exc:
            errors = [{**e, "loc": ("body", *e["loc"])} for e in exc.errors(include_url=False)]
            raise RequestValidationError(errors) from None
        return await self._endpoint(**request.path_params, **{self._name: body}, request=request)


class HotApp(FastAPI):
    """The FastAPI app, but a request for a hot route goes to its :class:`HotPath` at once: the
    framework's own outer layers (its telemetry and body-size wrappers, Starlette's 500
    middleware) do nothing for a step. An error no exception handler maps propagates to the
    server, which answers 500 and logs it, as it does past Starlette's middleware."""

    _hot: HotPath | None = None

    def build_middleware_stack(self) -> ASGIApp:
        stack = super().build_middleware_stack()
        self._hot = _within(stack, HotPath)
        return stack

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if self.middleware_stack is None:
            self.middleware_stack = self.build_middleware_stack()
        hot = self._hot
        route = None if hot is None else hot.match(scope)
        if hot is None or route is None:
            await super().__call__(scope, receive, send)
            return
        scope["app"] = self
        if self.root_path:
            scope["root_path"] = self.root_path
        await hot.serve(route, Request(scope, receive), send)


class JSONBytes(Response):
    """A 200 answer of JSON already encoded, its two headers made directly (Starlette's
    ``Response`` works them out from its arguments)."""

    media_type = "application/json"

    def __init__(self, body: bytes) -> None:
        self.status_code = 200
        self.background = None
        self.body = body
        self.raw_headers = [
            (b"content-length", b"%d" % len(body)),
            (b"content-type", b"application/json"),
        ]


class HotPath:
    """ASGI middleware serving the ``POST`` :class:`HotRoute` routes of ``routers`` (included
    in the app without a prefix) directly; errors go to the app's exception ``handlers`` (the
    ones ``service.errors.install`` registers). It wraps the service's other middlewares, and
    does what they do with their methods: ``app`` must hold an :class:`Observe`, an
    :class:`ApiKeys` and a :class:`BodyLimit`."""

    def __init__(
        self,
        app: ASGIApp,
        *,
        routers: Iterable[APIRouter],
        handlers: Mapping[Any, ExceptionHandler],
    ) -> None:
        self.app = app
        self._hot = [
            route
            for router in routers
            for route in router.routes
            if isinstance(route, HotRoute) and route.methods == {"POST"}
        ]
        self._handlers = handlers
        self._observe = _needed(app, Observe)
        self._keys = _needed(app, ApiKeys)
        self._limits = _needed(app, BodyLimit)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        route = self.match(scope)
        if route is None:
            await self.app(scope, receive, send)
        else:
            await self.serve(route, Request(scope, receive), send)

    def match(self, scope: Scope) -> HotRoute | None:
        """The hot route that serves the request, its path parameters put in the scope (with
        the route, as the router leaves them for metrics and logs), or None."""
        if scope["type"] == "http" and scope["method"] == "POST":
            for route in self._hot:
                match = route.path_regex.match(scope["path"])
                if match is not None:
                    scope["route"] = route
                    scope["endpoint"] = route.endpoint
                    scope["path_params"] = match.groupdict()
                    return route
        return None

    async def serve(self, route: HotRoute, request: Request, send: Send) -> None:
        """Serve a request ``route`` matched. Observe's part: the request id, then the answer,
        counted and logged."""
        began = time.perf_counter()
        request_id = request_id_of(request.scope)
        token = REQUEST_ID.set(request_id.decode())
        status = 500  # unless an answer starts
        try:
            response = await self._answer(route, request)
            if response is not None:
                assert response.background is None, "a hot route answers a plain Response"
                status = response.status_code
                headers = [*response.raw_headers, (HEADER, request_id)]
                await send({"type": "http.response.start", "status": status, "headers": headers})
                await send({"type": "http.response.body", "body": response.body})
        finally:
            self._observe.record(request.scope, status, began, request_id)
            REQUEST_ID.reset(token)

    async def _answer(self, route: HotRoute, request: Request) -> Response | None:
        """ApiKeys', BodyLimit's and the route's parts: the answer, an error's included, or
        ``None`` when the client went away before its body came."""
        try:
            tenant = self._keys.admit(request.scope)
            raw = await self._limits.read(request.scope, request.receive)
            if raw is None:
                return None
            token = TENANT.set(tenant)
            try:
                with self._limits.deadline():
                    return await route.answer(request, raw)
                raise self._limits.timed_out()  # only when the deadline stopped the block
            finally:
                TENANT.reset(token)
        except Exception as exc:
            handler = self._handler_for(exc)
            if handler is None:
                raise
            return cast(Response, await handler(request, exc))

    def _handler_for(self, exc: Exception) -> ExceptionHandler | None:
        for kind in type(exc).__mro__:
            if kind in self._handlers:
                return self._handlers[kind]
        return None


def _within(app: ASGIApp, kind: type[Middleware]) -> Middleware | None:
    """The middleware of type ``kind`` in the chain ``app`` leads (each holds the next as
    ``.app``), if any."""
    inner: Any = app
    while not isinstance(inner, kind):
        inner = getattr(inner, "app", None)
        if inner is None:
            return None
    return inner


def _needed(app: ASGIApp, kind: type[Middleware]) -> Middleware:
    found = _within(app, kind)
    if found is None:
        raise TypeError(f"HotPath wraps a {kind.__name__}: none in the middlewares it wraps")
    return found


def _content_type(scope: Scope) -> str | None:
    for name, value in scope["headers"]:
        if name == b"content-type":
            return bytes(value).decode("latin-1")
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

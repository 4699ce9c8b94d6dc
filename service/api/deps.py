"""Dependencies of the routers, as ``Annotated`` aliases, and the JSON-decoding route class."""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Annotated, Any, TypeVar, cast

import orjson
from fastapi import Depends, Query, Request, Response
from fastapi.dependencies.models import Dependant
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute
from pydantic import BaseModel, ValidationError
from starlette.datastructures import UploadFile
from starlette.exceptions import HTTPException
from starlette.formparsers import MultiPartException

import planner
from planner import quote
from schemas import StepCreate
from service.config import Settings
from service.edge.guards import check_depth, check_keys, key_limit
from service.errors import TooLarge, responses
from service.resources.maps import json_cells_message
from service.work.engine import Engine

__all__ = [
    "MULTIPART_PARTS",
    "PNG_ROUTE",
    "CellQuery",
    "CropQuery",
    "EngineDep",
    "MapRoute",
    "OrjsonRoute",
    "StepBody",
    "ZonesRoute",
    "check_json",
    "check_query",
    "get_engine",
    "json_body",
]

Model = TypeVar("Model", bound=BaseModel)


async def get_engine(request: Request) -> Engine:
    # async: FastAPI runs a plain def dependency in its threadpool, a needless hop per request
    return cast(Engine, request.app.state.engine)


EngineDep = Annotated[Engine, Depends(get_engine)]

CropQuery = Annotated[
    bool,
    Query(
        description="Draw only the known part of the map, its axes in meters (default); false: "
        "the whole map, unknown margins included, cell (0, 0) at the picture's top left.",
    ),
]
CellQuery = Annotated[
    int | None,
    Query(
        ge=1,
        le=64,
        description="Pixels per map cell (default: about 800 pixels across, 1 to 10 a cell); "
        "the picture may be at most 8192 pixels wide.",
    ),
]

PNG_ROUTE: dict[str, Any] = {
    "response_class": Response,
    "responses": {
        200: {"content": {"image/png": {}}, "description": "A PNG picture."},
        **responses(404, 413, 422),
    },
}
"""The arguments of a route that answers a PNG picture."""


class _OrjsonRequest(Request):
    async def json(self) -> Any:
        if not hasattr(self, "_json"):
            # orjson.JSONDecodeError subclasses json.JSONDecodeError, which FastAPI turns
            # into a 422; it also refuses integers beyond 64 bits that numpy could not hold.
            self._json = orjson.loads(await self.body())
        return self._json


def check_query(request: Request, allowed: frozenset[str]) -> None:
    """``InvalidInput`` (422) naming the first query parameter the route does not take: as for
    a body's fields, nothing unknown is ignored (a mistyped ``?cel=4`` would draw silently at
    the default size)."""
    for name in request.query_params:
        if name not in allowed:
            takes = ", ".join(sorted(allowed)) or "none"
            msg = f"{quote(name)}: unknown query parameter (this route takes: {takes})"
            raise planner.InvalidInput(msg, field=name[:100])


def _query_names(dependant: Dependant) -> frozenset[str]:
    """The query parameters an endpoint takes, its dependencies' included."""
    names = {p.alias for p in dependant.query_params}
    for sub in dependant.dependencies:
        names |= _query_names(sub)
    return frozenset(names)


class OrjsonRoute(APIRoute):
    """Decodes request bodies with orjson: several times faster than ``json`` on big maps; and
    refuses query parameters the route does not take."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()
        allowed = _query_names(self.dependant)

        async def route_handler(request: Request) -> Response:
            if request.scope.get("query_string"):
                check_query(request, allowed)
            request = _OrjsonRequest(request.scope, request.receive)
            # JSON is checked for depth before anything parses it; a multipart upload's parts
            # are bytes (an image) and JSON fields, each checked as it is read.
            multipart = request.headers.get("content-type", "").startswith("multipart/")
            if request.method in ("POST", "PUT", "PATCH") and not multipart:
                check_json(request, await request.body())
            request = await self.check_body(request)
            return await handler(request)

        return route_handler

    async def check_body(self, request: Request) -> Request:
        """A look at the raw body before it is parsed (errors raised here reach the handlers);
        the request to handle."""
        return request


def check_json(request: Request, body: bytes) -> None:
    """A JSON body's depth and number of keys, from its bytes, before it is parsed (422)."""
    check_depth(body)
    settings = cast(Settings, request.app.state.settings)
    zones = request.scope["path"].rstrip("/").endswith("/zones")
    check_keys(body, key_limit(settings.max_dynamic_obstacles, zones=zones))


async def json_body(request: Request, model: type[Model]) -> Model:
    """The request's body as ``model``, validated from its JSON bytes at once
    (``model_validate_json``), with the 422 a body parameter of that model gets: errors under
    ``body``; a body missing, malformed, or not declared JSON (``application/json`` or
    ``application/*+json``) refused, and one nesting too deep refused unparsed. For a route of
    the plain ``APIRoute`` class, which makes no second ``Request`` (:class:`OrjsonRoute`
    would read and check the body again)."""
    raw = await request.body()
    check_json(request, raw)
    if not raw:
        missing = {"type": "missing", "loc": ("body",), "msg": "Field required", "input": None}
        raise RequestValidationError([missing])
    media = request.headers.get("content-type", "").partition(";")[0].strip().lower()
    declared = media == "application/json" or (
        media.startswith("application/") and media.endswith("+json")
    )
    try:
        if declared:
            return model.model_validate_json(raw)
        return model.model_validate(raw, from_attributes=True)  # refused, in FastAPI's words
    except ValidationError as exc:
        raise _body_errors(exc, raw, model) from None


async def step_body(request: Request) -> StepCreate:
    """A step's body, read and checked by :func:`json_body` (the step's route is a plain
    ``APIRoute``: see ``add_step_route``); the step takes no query parameter."""
    if request.scope["query_string"]:
        check_query(request, frozenset())
    return await json_body(request, StepCreate)


StepBody = Annotated[StepCreate, Depends(step_body)]


def _body_errors(
    exc: ValidationError, raw: bytes, model: type[BaseModel]
) -> RequestValidationError:
    """pydantic's errors located under ``body``; malformed JSON as FastAPI words it (where the
    parser stopped, and why)."""
    errors = exc.errors(include_url=False)
    if errors and errors[0]["type"] == "json_invalid":
        try:
            orjson.loads(raw)
        except orjson.JSONDecodeError as bad:
            where = {"loc": ("body", bad.pos), "msg": "JSON decode error", "input": {}}
            return RequestValidationError(
                [{"type": "json_invalid", **where, "ctx": {"error": bad.msg}}]
            )
    # An unknown field's error carries the fields the body takes, for its message.
    fields = {"fields": tuple(model.model_fields)}
    return RequestValidationError(
        [
            {**e, "loc": ("body", *e["loc"])}
            | ({"ctx": fields} if e["type"] == "extra_forbidden" else {})
            for e in errors
        ]
    )


# Every cell of a map is one byte of the body: a Moving AI letter in `rows`, a 0 or a 1 in
# `grid`. Counting those bytes bounds the cells from above; a valid body's other fields (start,
# goal, preset, params) hold at most a few hundred of them, hence the slack.
_ALL_BYTES = bytes(range(256))
_NOT_CELLS = _ALL_BYTES.translate(None, b".GS@OTW01")
_NOT_LETTERS = _ALL_BYTES.translate(None, b".GS@OTW")
_NOT_NUMBERS = _ALL_BYTES.translate(None, b"01")
"""The bytes that are no map cell (no Moving AI letter, no 0 or 1 of a `grid`), no letter, and
no JSON number's cell (an OccupancyGrid's cells are counted by its commas)."""
CELL_SLACK = 4096


MULTIPART_PARTS = ("yaml", "image")
"""The multipart parts that stay bytes; every other form field is JSON (or a bare word)."""


class MapRoute(OrjsonRoute):
    """Refuses a map over ``PLANNER_MAX_MAP_CELLS`` from its raw bytes, before they become
    Python objects (the engine checks the exact shape after parsing), and reads a
    ``multipart/form-data`` upload into the fields of the JSON body.

    An OccupancyGrid's values take 1 to 3 digits each, so its body is bounded by its commas
    (one between two values) rather than by its digits.
    """

    async def check_body(self, request: Request) -> Request:
        if request.method != "POST":
            return request
        if request.headers.get("content-type", "").startswith("multipart/form-data"):
            return await _form_as_json(request)
        body = await request.body()
        # Counted by deleting every other byte: one fast pass of C each.
        if b'"occupancy_grid"' in body:
            numbers = body.count(b",")
            cells = max(numbers, len(body.translate(None, _NOT_LETTERS)))
        else:
            cells = len(body.translate(None, _NOT_CELLS))
            numbers = len(body.translate(None, _NOT_NUMBERS))
        settings = cast(Settings, request.app.state.settings)
        limit = settings.max_map_cells
        if cells > limit + CELL_SLACK:
            msg = (
                f"map: the body holds about {cells} map cells; PLANNER_MAX_MAP_CELLS is {limit} "
                "(refused before parsing)"
            )
            raise TooLarge(msg, field="map")
        if numbers > settings.max_json_map_cells + CELL_SLACK:
            message = json_cells_message(f"about {numbers}", settings.max_json_map_cells)
            raise TooLarge(message, field="map")
        return request


class ZonesRoute(OrjsonRoute):
    """Reads a ``multipart/form-data`` keepout mask (parts ``yaml`` and ``image``, polygons as
    JSON fields) into the fields of the JSON body, as :class:`MapRoute` does a map."""

    async def check_body(self, request: Request) -> Request:
        if request.method == "POST" and request.headers.get("content-type", "").startswith(
            "multipart/form-data"
        ):
            return await _form_as_json(request)
        return request


async def _form_as_json(request: Request) -> Request:
    """The form's fields as the JSON body's: the parts ``yaml`` and ``image`` as bytes, any
    other field's value parsed as JSON (``[0, 3]``, ``{"x": 1.5, "y": 2}``, ``0.22``, ``true``)
    or, when it is not JSON, kept as the text it is (``wide``, ``free``). The body model then
    validates them as it validates JSON (an unknown field is refused)."""
    fields: dict[str, Any] = {}
    try:
        form = await request.form(max_files=len(MULTIPART_PARTS), max_fields=32)
    except (MultiPartException, HTTPException) as exc:
        # A malformed form, or more parts than a map has: the client's mistake, a 422.
        detail = exc.message if isinstance(exc, MultiPartException) else exc.detail
        msg = f"body: the multipart form cannot be read: {detail}"
        raise planner.InvalidInput(msg, field="body") from None
    try:
        for name, value in form.multi_items():
            if isinstance(value, UploadFile) and name not in MULTIPART_PARTS:
                msg = (
                    f"{quote(name)}: a file part the upload does not take; a ROS map comes as "
                    "the parts 'yaml' (its map_server YAML) and 'image' (the PGM/PNG/BMP it "
                    "names): curl -F yaml=@map.yaml -F image=@map.pgm"
                )
                raise planner.InvalidInput(msg, field=name[:100])
            data = await value.read() if isinstance(value, UploadFile) else value.encode()
            if name in MULTIPART_PARTS:
                fields[name] = data
            else:
                check_depth(data, field=name)  # a form field's JSON, as deep as a body's
                text = data.decode("utf-8", "replace")
                try:
                    fields[name] = orjson.loads(text)
                except orjson.JSONDecodeError:
                    fields[name] = text
    finally:
        await form.close()
    # FastAPI reads a JSON body for the body model: this request is one, its JSON the fields.
    headers = [(k, v) for k, v in request.scope["headers"] if k != b"content-type"]
    scope = {**request.scope, "headers": [*headers, (b"content-type", b"application/json")]}
    parsed = _OrjsonRequest(scope, request.receive)
    parsed._body = b"{}"
    parsed._json = fields
    return parsed

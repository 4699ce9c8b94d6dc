"""The one place where errors become HTTP answers.

PlannerError (planner)                    HTTP
├── InvalidInput                          422 (START_OCCUPIED / GOAL_OCCUPIED when so named;
│                                         413 when its code is TOO_LARGE)
├── NoValidPath                           422, detail contains NO_VALID_PATH
└── SequenceConflict                      409
ServiceError (here)
├── Unauthorized      no or unknown API key          401, with WWW-Authenticate
├── NotFound          unknown map or plan            404
├── BodyTimeout       body not arrived in time       408, and the connection closes
├── TooLarge          body, map or picture too big   413
├── TooManyPlans      the key's plans at its cap     429
├── TooManyStreams    the key's streams at its cap   503, with Retry-After
├── InsufficientStorage  the map store is full       507
├── Busy              too many heavy jobs queued     503, with Retry-After
├── StoreUnavailable  the shared store (Redis) down  503, with Retry-After
└── TimedOut          over PLANNER_REQUEST_TIMEOUT   504
RequestValidationError (FastAPI)          422, first errors with where and what was received

A message never names internals (addresses, paths, exception text): those are logged.
"""

from __future__ import annotations

import re
import reprlib
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.types import Message, Scope, Send

import planner
from planner import QUOTE_LIMIT
from schemas import FRAME_ID_PATTERN, UNION_TAGS, ErrorPublic
from schemas.fleet_names import FLEET_PATTERN

__all__ = [
    "BodyTimeout",
    "Busy",
    "InsufficientStorage",
    "NotFound",
    "ServiceError",
    "StoreUnavailable",
    "TimedOut",
    "TooLarge",
    "TooManyPlans",
    "TooManyStreams",
    "Unauthorized",
    "install",
    "problem",
    "responses",
]


class ServiceError(Exception):
    """An error of the service itself (not of the planner)."""

    status = 400
    code = "BAD_REQUEST"

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field

    def __init_subclass__(cls, *, status: int, code: str, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.status, cls.code = status, code


class NotFound(ServiceError, status=404, code="NOT_FOUND"):
    """No map or plan has that id (or the plan expired)."""


class TooLarge(ServiceError, status=413, code="TOO_LARGE"):
    """A request body or map beyond the configured limits."""


class Unauthorized(ServiceError, status=401, code="UNAUTHORIZED"):
    """``PLANNER_API_KEYS`` is set and the request carries none of them."""


class BodyTimeout(ServiceError, status=408, code="BODY_TIMEOUT"):
    """The request body did not arrive within ``PLANNER_BODY_TIMEOUT_SECONDS``."""


class InsufficientStorage(ServiceError, status=507, code="STORE_FULL"):
    """The map store is full of maps that live plans still use."""


class TooManyPlans(ServiceError, status=429, code="TOO_MANY_PLANS"):
    """The key already has ``PLANNER_MAX_PLANS_PER_TENANT`` live plans."""


class TooManyStreams(ServiceError, status=503, code="TOO_MANY_STREAMS"):
    """The key already has ``PLANNER_MAX_STREAMS_PER_TENANT`` event streams open on this
    replica."""


class Busy(ServiceError, status=503, code="BUSY"):
    """Too many heavy jobs (analyses, plans, renders, simulations) are queued; retry later."""


class TimedOut(ServiceError, status=504, code="TIMED_OUT"):
    """The request ran over ``PLANNER_REQUEST_TIMEOUT_SECONDS``; its work was stopped."""


class StoreUnavailable(ServiceError, status=503, code="STORE_UNAVAILABLE"):
    """The store cannot be reached (or a plan's lock not taken) now; the client may retry.

    The stores raise it in place of their clients' errors (``redis.exceptions``), so nothing
    outside ``service/stores/`` knows which store runs.
    """


_PLANNER_STATUS: dict[type[planner.PlannerError], int] = {
    planner.InvalidInput: 422,
    planner.NoValidPath: 422,
    planner.SequenceConflict: 409,
}

_EXAMPLES: dict[int, dict[str, str | None]] = {
    401: {
        "detail": "an API key is needed: Authorization: Bearer <key> or X-API-Key: <key>",
        "field": None,
        "code": "UNAUTHORIZED",
    },
    404: {
        "detail": "plan_id: no plan '9f1c2a7b' (unknown, deleted or expired)",
        "field": "plan_id",
        "code": "NOT_FOUND",
    },
    409: {
        "detail": "seq 7 does not follow the last step's seq 4",
        "field": "seq",
        "code": "SEQUENCE_CONFLICT",
    },
    429: {
        "detail": "this key has 10000 live plans (PLANNER_MAX_PLANS_PER_TENANT); delete plans "
        "or wait for them to expire",
        "field": None,
        "code": "TOO_MANY_PLANS",
    },
    503: {
        "detail": "store unavailable; retry later",
        "field": None,
        "code": "STORE_UNAVAILABLE",
    },
    413: {
        "detail": "the request body has 70000000 bytes; PLANNER_MAX_BODY_BYTES is 33554432",
        "field": "body",
        "code": "TOO_LARGE",
    },
    504: {
        "detail": "the request ran over 30 s (PLANNER_REQUEST_TIMEOUT_SECONDS) and was stopped",
        "field": None,
        "code": "TIMED_OUT",
    },
    507: {
        "detail": "the map store is full: PLANNER_MAP_STORE_BYTES (2147483648) is taken by maps "
        "that live plans use; delete plans or retry when they expire",
        "field": "map",
        "code": "STORE_FULL",
    },
    422: {
        "detail": "start [3, 0] is outside the 3 x 3 map",
        "field": "start",
        "code": "INVALID_INPUT",
    },
}


def responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """``responses=`` for a route, so that ``/docs`` and clients know its errors' shape.

    Every route reaches the store and runs under the request timeout, so every route may
    answer 503 and 504; with ``PLANNER_API_KEYS`` set, 401 without a key.
    """
    return {
        status: {
            "model": ErrorPublic,
            "content": {"application/json": {"example": _EXAMPLES[status]}},
        }
        for status in (*statuses, 401, 503, 504)
    }


_OBJECT_REPR = re.compile(r"<[^<>]*? at 0x[0-9a-fA-F]+>")
"""An object's default repr (``<_io.BytesIO object at 0x7f...>``): a heap address."""

MAX_DETAIL = 600
"""Characters of an error's ``detail`` at most: messages quote at most ~100 characters of any
value received (:func:`planner.quote`); this bounds the whole, whatever raised it."""


def problem(status: int, message: str, *, field: str | None, code: str) -> JSONResponse:
    """An error answer whose ``detail`` names the field (when the message does not already)."""
    if field is not None and len(field) > QUOTE_LIMIT:
        field = field[: QUOTE_LIMIT - 3] + "..."
    if field and field.rsplit(".", 1)[-1] not in message.split(" ", 1)[0]:
        message = f"{field}: {message}"
    message = _OBJECT_REPR.sub("<object>", message)  # never an address, whoever raised it
    if len(message) > MAX_DETAIL:
        message = message[: MAX_DETAIL - 3] + "..."
    body = ErrorPublic(detail=message, field=field, code=code)
    # A 503 is transient: say when to come back (RFC 9110, 10.2.3).
    headers = {"Retry-After": "1"} if status == 503 else {}
    if status == 401:
        headers["WWW-Authenticate"] = 'Bearer realm="planner"'
    if status == 408:
        headers["Connection"] = "close"
    return JSONResponse(body.model_dump(), status_code=status, headers=headers or None)


async def send_problem(scope: Scope, send: Send, error: ServiceError) -> None:
    """Answer ``error`` from outside the app's handlers (a middleware, before the app)."""
    response = problem(error.status, error.message, field=error.field, code=error.code)

    async def nothing() -> Message:
        return {"type": "http.disconnect"}

    await response(scope, nothing, send)


async def _planner_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, planner.PlannerError)
    status = next((s for kind, s in _PLANNER_STATUS.items() if isinstance(exc, kind)), 422)
    if exc.code == TooLarge.code:  # an input over the planner's own limits (Pillow's pixels)
        status = TooLarge.status
    return problem(status, exc.message, field=exc.field, code=exc.code)


async def _service_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, ServiceError)
    return problem(exc.status, exc.message, field=exc.field, code=exc.code)


_LOOKED_AT = 32  # validation errors read to describe a 422


async def _validation_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, RequestValidationError)
    # The tags of the cell-or-point unions are no part of where the value was (a tag is never
    # loc[1], which names a body field or a query parameter, such as "cell").
    # Only the first errors are looked at: a body may hold tens of thousands.
    every = exc.errors()
    errors = [
        {**e, "loc": tuple(p for i, p in enumerate(e["loc"]) if i < 2 or p not in UNION_TAGS)}
        for e in every[:_LOOKED_AT]
    ]
    if any(e["loc"] == ("body",) and isinstance(e.get("input"), bytes) for e in errors):
        return problem(422, _not_json(request), field="content-type", code="INVALID_INPUT")
    # Unknown and missing body fields, each kind in one part: the body is not echoed (once
    # for each missing field, as pydantic gives it) and the fields the body takes are named.
    top = [e for e in errors if len(e["loc"]) == 2 and e["loc"][0] == "body"]
    unknown = [str(e["loc"][1]) for e in top if e["type"] == "extra_forbidden"]
    missing = [str(e["loc"][1]) for e in top if e["type"] == "missing"]
    rest = [e for e in errors if e["type"] not in ("extra_forbidden", "missing") or e not in top]
    parts, fields = [], [*unknown, *missing]
    if unknown:
        names = ", ".join(_quote_input(_cut(name)) for name in unknown[:5])
        takes = _body_fields(request, errors)
        parts.append(
            f"{names}: unknown field{'s' if len(unknown) > 1 else ''}"
            + (f" (the body takes: {', '.join(takes)})" if takes else "")
        )
    if missing:
        parts.append(f"{', '.join(_cut(name) for name in missing)}: Field required")
    # A map can be megabytes: echo only the start of what was received, and only a few errors.
    parts += [_describe(e) for e in rest[:3]]
    more = max(len(rest) - 3, 0) + max(len(unknown) - 5, 0) + len(every) - len(errors)
    if more > 0:
        parts.append(f"and {more} more errors")
    first = ("body", fields[0]) if fields else errors[0]["loc"] if errors else ()
    field = _path(first[1:]) or None
    return problem(422, "; ".join(parts), field=field, code="INVALID_INPUT")


def _not_json(request: Request) -> str:
    """What to do when the body came without a JSON content type (``curl -d`` sends
    ``application/x-www-form-urlencoded``)."""
    given = request.headers.get("content-type")
    got = f"Content-Type {_quote_input(given)}" if given else "no Content-Type"
    return (
        f"the request has {got}; send the body as JSON with the header "
        "Content-Type: application/json (curl: --json @body.json, or -H 'Content-Type: "
        "application/json' -d @body.json)"
    )


def _body_fields(request: Request, errors: list[Any]) -> list[str]:
    """The fields the route's body model takes: from the errors' context when the route read
    its body itself (:func:`service.api.deps.json_body`), else from the route's body field."""
    for error in errors:
        fields = (error.get("ctx") or {}).get("fields")
        if fields:
            return list(fields)
    body = getattr(request.scope.get("route"), "body_field", None)
    model = getattr(getattr(body, "field_info", None), "annotation", None)
    return list(getattr(model, "model_fields", {}))


def _path(loc: Any) -> str:
    """Where a value was, as the docs write it: ``keepout[0]``, ``agents[2].start``."""
    return "".join(
        f"[{p}]" if isinstance(p, int) else (f".{_cut(p)}" if i else _cut(p))
        for i, p in enumerate(loc)
    )


def _describe(error: Any) -> str:
    where = _path(error["loc"])
    message = error["msg"]
    ctx = error.get("ctx") or {}
    if error["type"] == "json_invalid":
        return f"{where}: malformed JSON at character {error['loc'][-1]}: {ctx.get('error', '')}"
    if error["type"] == "extra_forbidden":
        return f"{where}: unknown field (fields are checked strictly: see the schema)"
    if error["type"] == "value_error":  # a model's own check: its message is ours already
        message = message.removeprefix("Value error, ")
    words = _WORDS.get(error["type"])
    if words is not None:
        message = words.format(**ctx, actual=ctx.get("actual_length"))
    if error["type"] == "string_pattern_mismatch":
        message = PATTERN_WORDS.get(str(ctx.get("pattern")), message)
    return f"{where}: {message}; got {_quote_input(error.get('input'))}"


_WORDS = {
    "too_short": "needs at least {min_length} items",
    "too_long": "takes at most {max_length} items",
    "string_too_short": "needs at least {min_length} characters",
    "string_too_long": "takes at most {max_length} characters",
    "greater_than_equal": "must be at least {ge}",
    "greater_than": "must be more than {gt}",
    "less_than_equal": "must be at most {le}",
    "less_than": "must be less than {lt}",
}
"""pydantic's constraint errors in the project's words (its other messages are kept)."""

PATTERN_WORDS = {
    FLEET_PATTERN: "must be 1 to 64 letters, digits, `_`, `.` or `-` (no space)",
    FRAME_ID_PATTERN: "must be letters, digits, `_`, `.`, `/` or `-`",
}
"""The names' patterns in words: a client is never answered with a bare regex."""


# A received value may be nested deeply (up to the body's depth limit): its repr goes only a
# few levels down, so describing it can neither recurse far nor grow past the quote limit.
_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxstring, _REPR.maxother, _REPR.maxlong = 4, QUOTE_LIMIT, QUOTE_LIMIT, 40


def _quote_input(value: object) -> str:
    """A received value, shortened; bytes (a multipart part) only counted, never quoted."""
    if isinstance(value, bytes | bytearray):
        return f"<{len(value)} bytes>"
    if isinstance(value, dict) and any(isinstance(v, bytes | bytearray) for v in value.values()):
        value = {
            k: _Counted(v) if isinstance(v, bytes | bytearray) else v for k, v in value.items()
        }
    text = _REPR.repr(value)
    return text if len(text) <= QUOTE_LIMIT else f"{text[: QUOTE_LIMIT - 14]}... ({len(text)} ch)"


class _Counted:
    """Bytes in a quoted value: their length only."""

    def __init__(self, data: bytes | bytearray) -> None:
        self.size = len(data)

    def __repr__(self) -> str:
        return f"<{self.size} bytes>"


def _cut(name: object) -> str:
    text = str(name)
    return text if len(text) <= QUOTE_LIMIT else text[: QUOTE_LIMIT - 3] + "..."


_HTTP_CODES = {404: "NOT_FOUND", 405: "METHOD_NOT_ALLOWED"}


async def _http_error(request: Request, exc: Exception) -> JSONResponse:
    """Starlette's own answers (no such route, a method the route does not take) in the one
    shape of every error."""
    assert isinstance(exc, StarletteHTTPException)
    code = _HTTP_CODES.get(exc.status_code, "BAD_REQUEST")
    response = problem(exc.status_code, str(exc.detail), field=None, code=code)
    for name, value in (exc.headers or {}).items():
        response.headers[name] = value  # e.g. Allow on a 405
    return response


def install(app: FastAPI) -> None:
    """Map every error the service and the planner raise on purpose to its HTTP answer."""
    app.add_exception_handler(StarletteHTTPException, _http_error)
    app.add_exception_handler(planner.PlannerError, _planner_error)
    app.add_exception_handler(ServiceError, _service_error)
    app.add_exception_handler(RequestValidationError, _validation_error)

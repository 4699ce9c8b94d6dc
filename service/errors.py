"""The one place where errors become HTTP answers.

PlannerError (planner)                    HTTP
├── InvalidInput                          422 (START_OCCUPIED / GOAL_OCCUPIED when so named)
├── NoValidPath                           422, detail contains NO_VALID_PATH
└── SequenceConflict                      409
ServiceError (here)
├── NotFound          unknown map or plan            404
├── TooLarge          body or map too big            413
└── StoreUnavailable  the shared store (Redis) down  503, with Retry-After
RequestValidationError (FastAPI)          422, first errors with where and what was received
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

import planner
from planner._errors import QUOTE_LIMIT, quote
from schemas import UNION_TAGS, ErrorPublic

__all__ = [
    "NotFound",
    "ServiceError",
    "StoreUnavailable",
    "TooLarge",
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


class NotFound(ServiceError):
    """No map or plan has that id (or the plan expired)."""

    status = 404
    code = "NOT_FOUND"


class TooLarge(ServiceError):
    """A request body or map beyond the configured limits."""

    status = 413
    code = "TOO_LARGE"


class StoreUnavailable(ServiceError):
    """The store cannot be reached (or a plan's lock not taken) now; the client may retry.

    The stores raise it in place of their clients' errors (``redis.exceptions``), so nothing
    outside ``service/stores/`` knows which store runs.
    """

    status = 503
    code = "STORE_UNAVAILABLE"


_PLANNER_STATUS: dict[type[planner.PlannerError], int] = {
    planner.InvalidInput: 422,
    planner.NoValidPath: 422,
    planner.SequenceConflict: 409,
}

_EXAMPLES: dict[int, dict[str, str | None]] = {
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
    503: {
        "detail": "store unavailable: redis at redis:6379 refused the connection; retry later",
        "field": None,
        "code": "STORE_UNAVAILABLE",
    },
    413: {
        "detail": "the request body has 70000000 bytes; PLANNER_MAX_BODY_BYTES is 67108864",
        "field": "body",
        "code": "TOO_LARGE",
    },
    422: {
        "detail": "start [3, 0] is outside the 3 x 3 map",
        "field": "start",
        "code": "INVALID_INPUT",
    },
}


def responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """``responses=`` for a route, so that ``/docs`` and clients know its errors' shape.

    Every route reaches the store, so every route may answer 503.
    """
    return {
        status: {
            "model": ErrorPublic,
            "content": {"application/json": {"example": _EXAMPLES[status]}},
        }
        for status in (*statuses, 503)
    }


MAX_DETAIL = 600
"""Characters of an error's ``detail`` at most: messages quote at most ~100 characters of any
value received (:func:`planner.quote`); this bounds the whole, whatever raised it."""


def problem(status: int, message: str, *, field: str | None, code: str) -> JSONResponse:
    """An error answer whose ``detail`` names the field (when the message does not already)."""
    if field is not None and len(field) > QUOTE_LIMIT:
        field = field[: QUOTE_LIMIT - 3] + "..."
    if field and field.rsplit(".", 1)[-1] not in message.split(" ", 1)[0]:
        message = f"{field}: {message}"
    if len(message) > MAX_DETAIL:
        message = message[: MAX_DETAIL - 3] + "..."
    body = ErrorPublic(detail=message, field=field, code=code)
    # A 503 is transient: say when to come back (RFC 9110, 10.2.3).
    headers = {"Retry-After": "1"} if status == 503 else None
    return JSONResponse(body.model_dump(), status_code=status, headers=headers)


_NAMED_CODES = ("START_OCCUPIED", "GOAL_OCCUPIED")
"""Codes the planner puts first in an InvalidInput's message: the answer's ``code`` too."""


async def _planner_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, planner.PlannerError)
    status = next((s for kind, s in _PLANNER_STATUS.items() if isinstance(exc, kind)), 422)
    named = exc.message.split(":", 1)[0]
    code = named if named in _NAMED_CODES else exc.code
    return problem(status, exc.message, field=exc.field, code=code)


async def _service_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, ServiceError)
    return problem(exc.status, exc.message, field=exc.field, code=exc.code)


async def _validation_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, RequestValidationError)
    # The tags of the cell-or-point unions are no part of where the value was (a tag is never
    # loc[1], which names a body field or a query parameter, such as "cell").
    errors = [
        {**e, "loc": tuple(p for i, p in enumerate(e["loc"]) if i < 2 or p not in UNION_TAGS)}
        for e in exc.errors()
    ]
    # A map can be megabytes: echo only the start of what was received, and only a few errors.
    parts = [_describe(e) for e in errors[:3]]
    if len(errors) > 3:
        parts.append(f"and {len(errors) - 3} more errors")
    first = errors[0]["loc"] if errors else ()
    field = ".".join(_cut(p) for p in first[1:] if isinstance(p, str)) or None
    return problem(422, "; ".join(parts), field=field, code="INVALID_INPUT")


def _describe(error: Any) -> str:
    where = "".join(
        f"[{p}]" if isinstance(p, int) else (f".{_cut(p)}" if i else _cut(p))
        for i, p in enumerate(error["loc"])
    )
    message = error["msg"]
    ctx = error.get("ctx") or {}
    if error["type"] == "json_invalid":
        return f"{where}: malformed JSON at character {error['loc'][-1]}: {ctx.get('error', '')}"
    if error["type"] == "extra_forbidden":
        return f"{where}: unknown field (fields are checked strictly: see the schema)"
    return f"{where}: {message}; got {quote(error.get('input'))}"


def _cut(name: object) -> str:
    text = str(name)
    return text if len(text) <= QUOTE_LIMIT else text[: QUOTE_LIMIT - 3] + "..."


def install(app: FastAPI) -> None:
    """Map every error the service and the planner raise on purpose to its HTTP answer."""
    app.add_exception_handler(planner.PlannerError, _planner_error)
    app.add_exception_handler(ServiceError, _service_error)
    app.add_exception_handler(RequestValidationError, _validation_error)

"""The client's errors: one class an error answer, by its status and code (see the tree in
:mod:`service.client`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import httpx

__all__ = [
    "APIError",
    "BadRequestError",
    "ConflictError",
    "MapFileError",
    "NoValidPathError",
    "NotFoundError",
    "PayloadTooLargeError",
    "ServerError",
    "TooManyRequestsError",
    "UnavailableError",
    "ValidationError",
]


class APIError(Exception):
    """An error answer of the service."""

    def __init__(self, response: httpx.Response) -> None:
        self.response = response
        self.status_code = response.status_code
        body: Any
        try:
            body = response.json()
        except ValueError:
            body = None
        if not isinstance(body, dict):
            body = {"detail": response.text or response.reason_phrase}
        detail = body.get("detail")
        self.detail: str = detail if isinstance(detail, str) else json.dumps(detail)
        self.code: str = str(body.get("code") or f"HTTP_{response.status_code}")
        self.field: str | None = body.get("field")
        super().__init__(f"{self.status_code} {self.code}: {self.detail}")


class BadRequestError(APIError):
    """400."""


class NotFoundError(APIError):
    """404: no map or plan with that id (unknown, deleted or expired)."""


class ConflictError(APIError):
    """409: a step's ``seq`` is neither the last one nor the next one."""


class PayloadTooLargeError(APIError):
    """413: a body or a map over the service's limits."""


class ValidationError(APIError):
    """422: a request the service cannot accept; ``field`` names the input at fault."""


class NoValidPathError(ValidationError):
    """422 ``NO_VALID_PATH``: the goal cannot be reached from the start."""


class TooManyRequestsError(APIError):
    """429: the key holds its cap of live plans (``TOO_MANY_PLANS``)."""


class UnavailableError(APIError):
    """503: the service cannot take this now (the store out of reach, ``BUSY``, or the key's
    event streams at their cap, ``TOO_MANY_STREAMS``); retry after ``retry_after`` seconds."""

    @property
    def retry_after(self) -> float | None:
        value = self.response.headers.get("retry-after")
        try:
            return float(value) if value is not None else None
        except ValueError:
            return None


class ServerError(APIError):
    """Any other 5xx."""


class MapFileError(ValueError):
    """``upload_map(yaml=...)`` cannot read a map file: the YAML, or the image it names
    (``path``); raised before anything is sent."""

    def __init__(self, message: str, path: str | Path) -> None:
        super().__init__(message)
        self.path = Path(path)


_ERRORS: dict[int, type[APIError]] = {
    400: BadRequestError,
    404: NotFoundError,
    409: ConflictError,
    413: PayloadTooLargeError,
    422: ValidationError,
    429: TooManyRequestsError,
    503: UnavailableError,
}


def raise_for(response: httpx.Response) -> None:
    """Raise the :class:`APIError` an error answer stands for; nothing for a success."""
    if response.is_success:
        return
    kind = _ERRORS.get(response.status_code)
    if kind is None:
        kind = ServerError if response.status_code >= 500 else APIError
    error = kind(response)
    if kind is ValidationError and error.code == "NO_VALID_PATH":
        error = NoValidPathError(response)
    raise error

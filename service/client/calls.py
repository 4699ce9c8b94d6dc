"""The calls both clients send, each built once: a request and how to read its answer, and
the JSON a request's fields become."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

import httpx
from pydantic import BaseModel

from service.client.fields import CellIn

__all__ = ["Call", "R", "as_cell", "decode", "json_body", "png"]

R = TypeVar("R")
M = TypeVar("M", bound=BaseModel)


@dataclass(frozen=True)
class Call(Generic[R]):
    method: str
    url: str
    answer: Callable[[httpx.Response], R]
    content: Mapping[str, Any] = field(default_factory=dict)
    """httpx's ``json``, ``params``, ``data`` or ``files``."""


def decode(model: type[M]) -> Callable[[httpx.Response], M]:
    """The one decoder: the answer's JSON, validated as its response model."""
    return lambda response: model.model_validate_json(response.content)


def png(response: httpx.Response) -> bytes:
    if not response.content.startswith(b"\x89PNG"):
        raise ValueError(f"expected a PNG, got {response.headers.get('content-type')!r}")
    return response.content


def as_cell(cell: CellIn) -> Any:
    return dict(cell) if isinstance(cell, Mapping) else [int(v) for v in cell]


def json_body(fields: Mapping[str, Any]) -> dict[str, Any]:
    """The JSON body of the fields given; ``None`` is not sent."""
    body: dict[str, Any] = {}
    for name, value in fields.items():
        if value is None:
            continue
        if name in ("start", "goal", "position"):
            value = as_cell(value)
        elif name == "waypoints":
            value = [as_cell(point) for point in value]
        elif name == "grid":
            value = [list(row) for row in value]
        elif isinstance(value, Mapping):
            value = dict(value)
        elif isinstance(value, Sequence) and not isinstance(value, str):
            value = list(value)
        body[name] = value
    return body

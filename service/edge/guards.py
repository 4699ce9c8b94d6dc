"""Refuses a raw JSON body that nests too deep, from its bytes, before any recursive reader
(the parser, pydantic, ``repr``) sees it."""

from __future__ import annotations

import numpy as np

import planner
from planner import quote

__all__ = ["MAX_JSON_DEPTH", "check_depth", "json_depth"]

MAX_JSON_DEPTH = 64
"""Arrays and objects nested at most this deep in a request body (a valid one needs 4)."""

_OPEN = np.zeros(256, dtype=np.int8)
_OPEN[[ord("["), ord("{")]] = 1
_OPEN[[ord("]"), ord("}")]] = -1


def json_depth(body: bytes) -> int:
    """The deepest nesting of arrays and objects in ``body``, brackets inside strings not
    counted (for malformed JSON, a bound that the parser refuses anyway).

    >>> json_depth(b'{"a": [[1], "[[[["]}'), json_depth(b'"\\\\"'), json_depth(b"1")
    (3, 0, 0)
    """
    if not body:
        return 0
    # Escapes first, so that every quote left opens or closes a string.
    text = body.replace(b"\\\\", b"").replace(b'\\"', b"")
    raw = np.frombuffer(text, dtype=np.uint8)
    steps = _OPEN[raw]
    if not steps.any():
        return 0
    quotes = raw == ord('"')
    if quotes.any():
        inside = (np.cumsum(quotes) & 1).astype(bool)  # a closing quote counts as inside
        steps = np.where(inside, 0, steps)
    return int(np.cumsum(steps, dtype=np.int64).max(initial=0))


def check_depth(body: bytes, limit: int = MAX_JSON_DEPTH, *, field: str = "body") -> None:
    """``InvalidInput`` (422) naming the depth when ``body`` (the JSON body, or the form field
    ``field``) nests deeper than ``limit``."""
    if body.count(b"[") + body.count(b"{") <= limit:
        return  # cannot nest deeper than it has brackets: most bodies stop here (~1 us)
    depth = json_depth(body)
    if depth > limit:
        what = "the JSON body" if field == "body" else f"{quote(field)} (a form field)"
        msg = f"{what} nests {depth} levels deep; the limit is {limit} (refused unparsed)"
        raise planner.InvalidInput(msg, field=field[:100])

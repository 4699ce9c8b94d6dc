"""Refuses a raw JSON body that nests too deep, or holds too many object keys, from its
bytes, before any recursive reader (the parser, pydantic, ``repr``) sees it: validating a
million unknown keys is a million errors, seconds and a gigabyte."""

from __future__ import annotations

import numpy as np

import planner

__all__ = ["MAX_JSON_DEPTH", "check_depth", "check_keys", "json_depth", "json_keys", "key_limit"]

MAX_JSON_DEPTH = 64
"""Arrays and objects nested at most this deep in a request body (a valid one needs 4)."""

_OPEN = np.zeros(256, dtype=np.int8)
_OPEN[[ord("["), ord("{")]] = 1
_OPEN[[ord("]"), ord("}")]] = -1


def _outside_strings(body: bytes) -> tuple[np.ndarray, np.ndarray | None]:
    """The body's bytes (escapes removed) and where they lie outside strings (None: no string
    at all)."""
    # Escapes first, so that every quote left opens or closes a string.
    text = body.replace(b"\\\\", b"").replace(b'\\"', b"")
    raw = np.frombuffer(text, dtype=np.uint8)
    quotes = raw == ord('"')
    if not quotes.any():
        return raw, None
    # Parity of the quotes so far, a byte each (a cumsum would take 8).
    inside = np.bitwise_xor.accumulate(quotes.view(np.uint8))
    return raw, inside == 0  # a closing quote counts as outside


def json_depth(body: bytes) -> int:
    """The deepest nesting of arrays and objects in ``body``, brackets inside strings not
    counted (for malformed JSON, a bound that the parser refuses anyway).

    >>> json_depth(b'{"a": [[1], "[[[["]}'), json_depth(b'"\\\\"'), json_depth(b"1")
    (3, 0, 0)
    """
    if not body:
        return 0
    raw, outside = _outside_strings(body)
    steps = _OPEN[raw]
    if not steps.any():
        return 0
    if outside is not None:
        steps = np.where(outside, steps, 0)
    return int(np.cumsum(steps, dtype=np.int32).max(initial=0))


def json_keys(body: bytes) -> int:
    """The object keys in ``body`` (its colons outside strings).

    >>> json_keys(b'{"a": {"b:c": 1, "d": [{"e": ":"}]}}')
    4
    """
    raw, outside = _outside_strings(body)
    colons = raw == ord(":")
    return int(np.count_nonzero(colons if outside is None else colons & outside))


def key_limit(max_dynamic_obstacles: int) -> int:
    """The most object keys a request body may hold: three for each circle a step may give,
    and 1024 for everything else (a valid map, plan or simulation needs a few dozen)."""
    return 3 * max_dynamic_obstacles + 1024


def check_keys(body: bytes, limit: int) -> None:
    """``InvalidInput`` (422) naming the count when ``body`` holds more than ``limit`` object
    keys (refused unparsed: each unknown key would be an error of its own)."""
    if body.count(b":") <= limit:
        return  # cannot hold more keys than it has colons: most bodies stop here
    keys = json_keys(body)
    if keys > limit:
        msg = (
            f"the JSON body holds {keys} object keys; the limit is {limit} (3 for each of "
            "PLANNER_MAX_DYNAMIC_OBSTACLES, and 1024; refused unparsed)"
        )
        raise planner.InvalidInput(msg, field="body")


def check_depth(body: bytes, limit: int = MAX_JSON_DEPTH) -> None:
    """``InvalidInput`` (422) naming the depth when ``body`` nests deeper than ``limit``."""
    if body.count(b"[") + body.count(b"{") <= limit:
        return  # cannot nest deeper than it has brackets: most bodies stop here (~1 us)
    depth = json_depth(body)
    if depth > limit:
        msg = f"the JSON body nests {depth} levels deep; the limit is {limit} (refused unparsed)"
        raise planner.InvalidInput(msg, field="body")

"""Refuses a raw JSON body that nests too deep, or holds too many object keys, from its
bytes, before any recursive reader (the parser, pydantic, ``repr``) sees it: validating a
million unknown keys is a million errors, seconds and a gigabyte."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import numpy.typing as npt

import planner
from planner import quote
from schemas.zones import POLYGON_POINTS_MAX, ZONES_MAX

__all__ = ["MAX_JSON_DEPTH", "check_depth", "check_keys", "json_depth", "json_keys", "key_limit"]

MAX_JSON_DEPTH = 64
"""Arrays and objects nested at most this deep in a request body (a valid one needs 4)."""

_OPEN = np.zeros(256, dtype=np.int8)
_OPEN[[ord("["), ord("{")]] = 1
_OPEN[[ord("]"), ord("}")]] = -1
_NOT_OPENING = bytes(range(256)).translate(None, b"[{")


_PREFIX = 1 << 16
"""Bytes of a large body looked at first, for the depth."""
_CHUNK = 1 << 22
"""Bytes looked at at once: the positions found in a chunk take 8 bytes each."""


def _outside_strings(body: bytes, marks: bytes) -> Iterator[npt.NDArray[np.uint8]]:
    """The bytes of ``body`` that are among ``marks`` and that lie outside
    strings, in order, a chunk at a time: a string opens at an odd quote, so a byte is outside
    when an even number of quotes come before it. The work is the flagged bytes and the
    quotes (numpy, sparse), never a Python step per byte."""
    # Escapes first, so that every quote left opens or closes a string.
    text = body.replace(b"\\\\", b"").replace(b'\\"', b"") if b"\\" in body else body
    raw = np.frombuffer(text, dtype=np.uint8)
    quotes_before = 0
    for start in range(0, raw.size, _CHUNK):
        chunk = raw[start : start + _CHUNK]
        flagged = chunk == marks[0]
        for mark in marks[1:]:
            flagged |= chunk == mark  # comparisons: several times faster than a table look-up
        where = np.flatnonzero(flagged)
        quotes = np.flatnonzero(chunk == ord('"'))
        if where.size and quotes.size:
            where = where[((np.searchsorted(quotes, where) + quotes_before) & 1) == 0]
        elif where.size and quotes_before & 1:
            where = where[:0]
        quotes_before += quotes.size
        yield chunk[where]


def json_depth(body: bytes) -> int:
    """The deepest nesting of arrays and objects in ``body``, brackets inside strings not
    counted (for malformed JSON, a bound that the parser refuses anyway).

    >>> json_depth(b'{"a": [[1], "[[[["]}'), json_depth(b'"\\\\"'), json_depth(b"1")
    (3, 0, 0)
    """
    return _depth(body, None)[0]


def _depth(body: bytes, stop: int | None) -> tuple[int, bool]:
    """:func:`json_depth`, looking no further than the chunk where it passes ``stop``; and
    whether the whole body was looked at."""
    depth = deepest = 0
    for brackets in _outside_strings(body, b"[]{}"):
        if brackets.size:
            levels = np.cumsum(_OPEN[brackets], dtype=np.int64) + depth
            deepest = max(deepest, int(levels.max()))
            depth = int(levels[-1])
            if stop is not None and deepest > stop:
                return deepest, len(body) <= _CHUNK  # looked at whole if one chunk
    return deepest, True


def json_keys(body: bytes) -> int:
    """The object keys in ``body`` (its colons outside strings).

    >>> json_keys(b'{"a": {"b:c": 1, "d": [{"e": ":"}]}}')
    4
    """
    return sum(colons.size for colons in _outside_strings(body, b":"))


def key_limit(max_dynamic_obstacles: int, *, zones: bool = False) -> int:
    """The most object keys a request body may hold: three for each circle a step may give,
    and 1024 for everything else (a valid map, plan or simulation needs a few dozen); a zones
    body, two for each point its polygons may have and two for each polygon."""
    if zones:
        return 2 * ZONES_MAX * POLYGON_POINTS_MAX + 2 * ZONES_MAX + 1024
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


def check_depth(body: bytes, limit: int = MAX_JSON_DEPTH, *, field: str = "body") -> None:
    """``InvalidInput`` (422) naming the depth when ``body`` (the JSON body, or the form field
    ``field``) nests deeper than ``limit``."""
    depth, whole = 0, True
    if len(body) > _PREFIX:  # a body nesting too deep mostly does so from its start
        depth, _ = _depth(body[:_PREFIX], limit)
        whole = False
    if depth <= limit:
        if len(body.translate(None, _NOT_OPENING)) <= limit:
            return  # cannot nest deeper than it has brackets: most bodies stop here (~1 us)
        depth, whole = _depth(body, limit)
    if depth > limit:
        deep = f"{depth}" if whole else f"at least {depth}"
        what = "the JSON body" if field == "body" else f"{quote(field)} (a form field)"
        msg = f"{what} nests {deep} levels deep; the limit is {limit} (refused unparsed)"
        raise planner.InvalidInput(msg, field=field[:100])

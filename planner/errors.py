"""The planner's errors: one small hierarchy, each with a stable machine-readable ``code``.

PlannerError
├── InvalidInput        (also a ValueError) a grid, map text, cell or parameter is unusable
├── NoValidPath         ``NO_VALID_PATH``: the goal cannot be reached
└── SequenceConflict    a step's ``seq`` is neither the last one nor the next one
"""

from __future__ import annotations

from collections.abc import Iterator

__all__ = ["InvalidInput", "NoValidPath", "PlannerError", "SequenceConflict", "quote"]

QUOTE_LIMIT = 100
"""Characters of a received value that an error message quotes at most."""


def quote(value: object, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` cut to ``limit`` characters: error messages name what they received
    without echoing megabytes of it. The repr is built piece by piece and stops at the limit,
    so a huge or deeply nested value (a YAML alias bomb, a million-element list) costs about
    ``limit`` characters of work, never its whole repr.

    >>> quote("x" * 500)[-16:]
    'xxxx... (500 ch)'
    >>> quote([1, 2]), quote({"a": (1, None)})
    ('[1, 2]', "{'a': (1, None)}")
    >>> quote([list(range(10**6))] * 10**6)[-12:]
    '24, 25, 2...'
    """
    pieces: list[str] = []
    size = 0
    for piece in _repr_pieces(value, limit, 0):
        pieces.append(piece)
        size += len(piece)
        if size > limit:
            break
    text = "".join(pieces)
    if size <= limit:
        return text
    if isinstance(value, str | bytes):  # its length is known: say it
        return f"{text[: limit - 14]}... ({len(value)} ch)"
    return f"{text[: limit - 3]}..."


_QUOTE_DEPTH = 20
"""Containers quoted this deep at most (deeper: ``...``), so that no recursion runs away."""


def _repr_pieces(value: object, budget: int, depth: int) -> Iterator[str]:
    """``repr(value)`` in pieces, lazily: the caller stops reading once it has enough. Strings,
    bytes and integers are cut before their repr is built; containers are walked."""
    if isinstance(value, str | bytes):
        yield repr(value[: budget + 1])
    elif type(value) is int and value.bit_length() > 4 * budget:
        yield f"<an integer of {value.bit_length()} bits>"
    elif isinstance(value, list | tuple | set | frozenset | dict):
        if depth >= _QUOTE_DEPTH:
            yield "..."
            return
        if isinstance(value, dict):
            opening, closing = "{", "}"
        elif isinstance(value, list):
            opening, closing = "[", "]"
        elif isinstance(value, tuple):
            opening, closing = "(", ",)" if len(value) == 1 else ")"
        elif isinstance(value, set):
            opening, closing = "{", "}"
        else:
            opening, closing = "frozenset({", "})"
        yield opening
        for i, item in enumerate(value):
            if i:
                yield ", "
            if isinstance(value, dict):
                yield from _repr_pieces(item, budget, depth + 1)
                yield ": "
                item = value[item]
            yield from _repr_pieces(item, budget, depth + 1)
        yield closing
    else:
        yield repr(value)


class PlannerError(Exception):
    """Base of every error the planner raises on purpose.

    ``field`` names the input at fault (``"start"``, ``"params.alpha"``...) when there is one;
    ``code``, when given, a more precise code than the class's (``"START_OCCUPIED"``).
    """

    code = "PLANNER_ERROR"

    def __init__(self, message: str, *, field: str | None = None, code: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field
        if code is not None:
            self.code = code


class InvalidInput(PlannerError, ValueError):
    """A grid, map text, scenario, cell or parameter that the planner cannot use."""

    code = "INVALID_INPUT"


class NoValidPath(PlannerError):
    """The goal cannot be reached from the start (the message starts with ``NO_VALID_PATH``)."""

    code = "NO_VALID_PATH"

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(f"NO_VALID_PATH: {message}", field=field)


class SequenceConflict(PlannerError):
    """A step's ``seq`` is neither the last step's (a retry) nor the next one."""

    code = "SEQUENCE_CONFLICT"

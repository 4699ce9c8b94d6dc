"""The planner's errors: one small hierarchy, each with a stable machine-readable ``code``.

PlannerError
├── InvalidInput        (also a ValueError) a grid, map text, cell or parameter is unusable
├── NoValidPath         ``NO_VALID_PATH``: the goal cannot be reached
└── SequenceConflict    a step's ``seq`` is neither the last one nor the next one
"""

from __future__ import annotations

__all__ = ["InvalidInput", "NoValidPath", "PlannerError", "SequenceConflict", "quote"]

QUOTE_LIMIT = 100
"""Characters of a received value that an error message quotes at most."""


def quote(value: object, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` cut to ``limit`` characters: error messages name what they received
    without echoing megabytes of it.

    >>> quote("x" * 500)[-12:]
    '... (502 ch)'
    >>> quote([1, 2])
    '[1, 2]'
    """
    text = repr(value)
    if len(text) <= limit:
        return text
    return f"{text[: limit - 14]}... ({len(text)} ch)"


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

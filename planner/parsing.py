"""The parsers of the planner's input values, one per shape: numbers, points in meters. Each
refuses what it cannot read exactly, naming the field at fault and what it received, so that
every place that takes a value of that shape refuses the same things.

>>> point({"x": 1, "y": 2.5}, "goal")
(1.0, 2.5)
>>> point({"x": 1, "y": 2, "z": 0}, "goal")
Traceback (most recent call last):
...
planner.errors.InvalidInput: goal must be a point {x, y} in meters ('x' and 'y', no other key); \
got {'x': 1, 'y': 2, 'z': 0}
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from planner.errors import InvalidInput, quote

__all__ = ["COORDINATE_MAX", "number", "point"]

COORDINATE_MAX = 1e9
"""Meters from 0 a point's coordinates stay within."""


def number(value: Any, field: str, what: str = "a finite number") -> float:
    """``value`` as a float: a real number (not a bool), finite; else InvalidInput naming
    ``field`` and saying it must be ``what``."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise InvalidInput(f"{field} must be {what}; got {quote(value)}", field=field)
    out = float(value)
    if not math.isfinite(out):
        raise InvalidInput(f"{field} must be {what}; got {quote(value)}", field=field)
    return out


def point(value: Any, field: str, *, also: tuple[str, ...] = ()) -> tuple[float, float]:
    """A point in meters as ``(x, y)`` floats, from ``{"x", "y"}`` (no other key but those of
    ``also``, read elsewhere: a pose's ``"yaw"``) or a pair: finite numbers at most
    :data:`COORDINATE_MAX` from 0; else InvalidInput naming ``field``."""
    if isinstance(value, Mapping):
        unknown = sorted(str(k) for k in value if k not in ("x", "y", *also))
        if unknown or "x" not in value or "y" not in value:
            keys = "".join(f", {k!r}" for k in also)
            msg = (
                f"{field} must be a point {{x, y}} in meters ('x' and 'y'{keys}, no other key); "
                f"got {quote(value)}"
            )
            raise InvalidInput(msg, field=field)
        values = [value["x"], value["y"]]
    elif isinstance(value, Sequence | np.ndarray) and not isinstance(value, str | bytes):
        values = list(value)
    else:
        raise InvalidInput(f"{field} must be a point {{x, y}}; got {quote(value)}", field=field)
    ok = len(values) == 2 and all(
        isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool)
        for v in values
    )
    if not ok or not all(math.isfinite(float(v)) and abs(v) <= COORDINATE_MAX for v in values):
        msg = (
            f"{field} must be a point of finite numbers in meters (at most {COORDINATE_MAX:g} "
            f"from 0); got {quote(value)}"
        )
        raise InvalidInput(msg, field=field)
    return float(values[0]) + 0.0, float(values[1]) + 0.0

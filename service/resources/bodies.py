"""What the resources read of a request's body: its cells or points as the planner takes them,
and the planner parameters it overrides (the engine below knows no HTTP schema)."""

from __future__ import annotations

from typing import Any

import planner
from planner import quote
from schemas import PlanCreate, Point, SimulationCreate

__all__ = ["overrides", "where"]


def where(value: list[int] | Point) -> Any:
    """A request's cell (``[row, col]``) or point (``{"x", "y"}``, and ``"yaw"`` when given),
    as the planner takes it."""
    return value.model_dump(exclude_none=True) if isinstance(value, Point) else value


def overrides(body: PlanCreate | SimulationCreate) -> dict[str, Any]:
    """The planner parameters a request overrides: ``params``, with ``allow_narrow``,
    ``robot_radius``, ``unknown``, ``footprint``, ``motion`` and ``min_turning_radius`` on top
    (given both ways, they must agree)."""
    out = dict(body.params)
    for name in ("allow_narrow", "robot_radius", "unknown", "footprint", "motion",
                 "min_turning_radius"):  # fmt: skip
        value = getattr(body, name)
        if value is None:
            continue
        if name in out and out[name] != value:
            msg = (
                f"{name} {quote(value)} and params.{name} {quote(out[name])} disagree; "
                "give one of them"
            )
            raise planner.InvalidInput(msg, field=name)
        out[name] = value
    return out

"""A fleet's name, as requests give it (``POST /plan``, ``POST /maps``) and routes take it; and
``PlanCreate`` with its ``fleet`` (``schemas.PlanCreate``: the plan's request as the API takes
it, ``schemas.plans.PlanCreate`` with the fleet a robot belongs to)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from schemas.plans import PlanCreate as PlanCreateBase

__all__ = ["FLEET_PATTERN", "FleetName", "PlanCreate"]

FLEET_PATTERN = r"^[A-Za-z0-9_.-]{1,64}$"
"""A fleet's name: 1 to 64 letters, digits, ``_``, ``.``, ``-``."""

FleetName = Annotated[
    str | None,
    Field(
        default=None,
        min_length=1,
        max_length=64,
        pattern=FLEET_PATTERN,
        description="The fleet the robot belongs to (1-64 characters of `[A-Za-z0-9_.-]`, the "
        "API key's own): the fleet's robots are planned together on a roadmap of the map and "
        "each step answers the moves of the joint plan it may make now (docs/fleets.md). Every "
        "plan of a fleet is on one map (else `422` `FLEET_MAP_MISMATCH`).",
        examples=["warehouse-a"],
    ),
]
"""A plan's fleet."""


class PlanCreate(PlanCreateBase):
    """Ask for a plan from ``start`` to ``goal`` on a map already uploaded."""

    fleet: FleetName = None

"""``/fleets/{fleet}``: the robots of a fleet as they stand."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path

from schemas import FleetPublic
from schemas.plans import FLEET_PATTERN
from service.api import present
from service.api.deps import EngineDep, OrjsonRoute
from service.errors import responses
from service.resources import fleets

__all__ = ["router"]

router = APIRouter(tags=["fleets"], route_class=OrjsonRoute)

FleetPath = Annotated[str, Path(min_length=1, max_length=64, pattern=FLEET_PATTERN)]


@router.get("/fleets/{fleet}", summary="The robots of a fleet", responses=responses(404, 422))
async def get_fleet(fleet: FleetPath, engine: EngineDep) -> FleetPublic:
    """Every robot of the fleet (the API key's own), by priority: its `plan_id`, the cell it was
    last told to move to (`position`, `position_xy`), its `status` and, waiting, the robot it
    `waiting_for`; and the map's narrow passages for the fleet's radius with the robots holding
    each. `404` when no plan of the fleet is alive."""
    return present.fleet_public(await fleets.get_fleet(engine, fleet))

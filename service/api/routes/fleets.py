"""``/fleets/{fleet}``: the robots of a fleet as they stand."""

from __future__ import annotations

import html
from importlib import resources
from typing import Annotated

import orjson
from fastapi import APIRouter, Path, Query
from fastapi.responses import HTMLResponse

from schemas import FleetPublic
from schemas.fleet_names import FLEET_PATTERN
from service.api import present
from service.api.deps import EngineDep, OrjsonRoute
from service.errors import responses
from service.resources import fleets

__all__ = ["router"]

router = APIRouter(tags=["fleets"], route_class=OrjsonRoute)

FleetPath = Annotated[str, Path(min_length=1, max_length=64, pattern=FLEET_PATTERN)]


PAGE = (resources.files("service.viewer") / "fleet.html").read_text(encoding="utf-8")
POLL_MS = 250
"""How often the fleet page reads the fleet."""


@router.get("/fleets/{fleet}", summary="The robots of a fleet", responses=responses(404, 422))
async def get_fleet(
    fleet: FleetPath,
    engine: EngineDep,
    ahead: Annotated[
        bool, Query(description="Also each robot's path ahead (its last step's `poses`).")
    ] = False,
) -> FleetPublic:
    """Every robot of the fleet (the API key's own), in the order they joined: its `plan_id`,
    the cell it was last told to move to (`position`, `position_xy`), its `status` and, waiting,
    the robot it is `waiting_for`, the roadmap nodes it still has to visit (`remaining`) and its
    moves done of the joint plan; and the joint plan's last `solve`. `404` when no plan of the
    fleet is alive."""
    return present.fleet_public(await fleets.get_fleet(engine, fleet, ahead=ahead))


@router.get(
    "/fleets/{fleet}/view",
    summary="A live page of the fleet on its map",
    response_class=HTMLResponse,
    responses={200: {"content": {"text/html": {}}}, **responses(404, 422)},
)
async def view(fleet: FleetPath, engine: EngineDep) -> HTMLResponse:
    """An HTML page drawing the fleet's map, every robot (`.robot`, its cell in `data-cell`, its
    `data-status` and `data-waiting-for`), its heading (`.heading`, `data-yaw`), its path ahead
    (`.ahead`), its route left (`.route`) and goal, numbered in its disc and listed below the
    map (`#list`: status, whom it waits for, moves done), read from
    `/fleets/{fleet}?ahead=true` a few times a second (from any replica). The map fills the
    window, zooms with the wheel and pans with a drag; a scale bar says its meters.
    Everything it loads comes from the service."""
    view_ = await fleets.get_fleet(engine, fleet, ahead=True)
    height, width = view_.shape
    frame = view_.frame
    data = {
        "fleet": fleet,
        "map_id": view_.state["map_id"],
        "robot_radius": view_.state["radius"],
        "height": height,
        "width": width,
        "cell": max(1, min(32, 900 // max(height, width))),
        "resolution": frame.resolution,
        "origin": list(frame.origin),
        "interval_ms": POLL_MS,
        "initial": present.fleet_public(view_).model_dump(mode="json"),
    }
    # Inside <script>: "</" must not close it.
    embedded = orjson.dumps(data).decode().replace("</", "<\\/")
    page = PAGE.replace("__FLEET__", html.escape(fleet))
    return HTMLResponse(page.replace("__FLEET_DATA__", embedded))

"""``/maps/{map_id}/zones``: keepout and speed zones on a stored map, as a new map."""

from __future__ import annotations

from fastapi import APIRouter, Response, status

from schemas import ZONES_MULTIPART, MapPublic, ZonesCreate
from service.api import present
from service.api.deps import EngineDep, ZonesRoute
from service.errors import responses
from service.resources import zones

__all__ = ["router"]

router = APIRouter(tags=["maps"], route_class=ZonesRoute)


@router.post(
    "/maps/{map_id}/zones",
    status_code=status.HTTP_201_CREATED,
    summary="Zone a map: keepout and speed zones, as a new map",
    responses={
        200: {"model": MapPublic, "description": "The zoned map was known already."},
        **responses(404, 413, 422, 507),
    },
    openapi_extra={
        "requestBody": {"content": {"multipart/form-data": {"schema": ZONES_MULTIPART}}}
    },
)
async def create_zones(
    map_id: str, body: ZonesCreate, engine: EngineDep, response: Response
) -> MapPublic:
    """Apply zones to the stored map `map_id`: `keepout` polygons (every cell whose center one
    holds is blocked) and `speed` zones (`{"polygon", "max_speed"}`: poses inside carry
    `max_speed`), points `{"x", "y"}` in meters in the map's frame; or, as
    `multipart/form-data`, a Nav2 keepout filter mask in the parts `yaml` and `image` (a
    map_server map of the same size, resolution and origin: an occupied cell is keepout).
    Answers `201` (`200` when it was known already) and a new map (`zones` lists what it has,
    its base map's zones first), whose id hashes its cells and zones: the same zones on the
    same map give the same id. The base map is unchanged, and its cells are not sent again.
    Plans on the zoned map never enter a keepout cell, with the robot's radius kept from it as
    from any blocked cell."""
    view, created = await zones.add_zones(engine, map_id, body)
    if not created:
        response.status_code = status.HTTP_200_OK
    return present.map_public(view)

"""``/maps``: upload a map (optionally planning on it at once) and read its metadata."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Query, Response, status

from schemas import MapCreate, MapPublic, Preset
from service import maps
from service.api import present
from service.api.deps import PNG_RESPONSE, CellQuery, EngineDep, MapRoute
from service.errors import responses

__all__ = ["router"]

ERRORS = responses(404, 413, 422, 507)

router = APIRouter(tags=["maps"], route_class=MapRoute)


@router.post(
    "/maps",
    status_code=status.HTTP_201_CREATED,
    summary="Upload a map, and plan on it when start and goal are given",
    responses={200: {"model": MapPublic, "description": "The map was known already."}, **ERRORS},
)
async def create_map(body: MapCreate, engine: EngineDep, response: Response) -> MapPublic:
    """Upload a map as `grid` (0 free, 1 blocked) or as Moving AI `rows`. Its `map_id` is the
    hex SHA-256 of its shape and cells: the same whichever encoding was sent. `201` the first
    time, `200` after. With `start` and `goal` (and `preset`, `params`, `allow_narrow`) a plan
    is created too and returned under `plan`, as from `POST /plan`."""
    view, created = await maps.add_map(engine, body)
    if not created:
        response.status_code = status.HTTP_200_OK
    return present.map_public(view)


@router.get("/maps/{map_id}", summary="A map's metadata", responses=responses(404, 422))
async def get_map(map_id: str, engine: EngineDep) -> MapPublic:
    """The `map_id`, `height`, `width` and `free_cells` of an uploaded map."""
    return present.map_public(await maps.get_map(engine, map_id))


@router.get(
    "/maps/{map_id}/render.png",
    summary="A picture of the map and its analysis",
    response_class=Response,
    responses={**PNG_RESPONSE, **responses(404, 413, 422)},
)
async def render_map(
    map_id: str,
    engine: EngineDep,
    preset: Annotated[Preset, Query(description="Whose analysis to draw.")] = "wide",
    field: Annotated[
        Literal["clean"] | None, Query(description="Tint free cells by their clean penalty.")
    ] = None,
    cell: CellQuery = None,
) -> Response:
    """The map as the paper draws it: obstacles black, tight-tunnel cells orange (when the
    preset seals them), gates red; with `field=clean`, free cells tinted by their penalty."""
    png = await maps.render_map(engine, map_id, preset, field, cell)
    return Response(png, media_type="image/png")

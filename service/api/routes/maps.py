"""``/maps``: upload a map (optionally planning on it at once) and read its metadata."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Query, Response, status

from schemas import MULTIPART_FIELDS, MapCreate, MapPublic, PassagesPublic, Preset
from schemas.plans import Unknown
from service.api import present
from service.api.deps import PNG_ROUTE, CellQuery, CropQuery, EngineDep, MapRoute
from service.errors import responses
from service.resources import maps
from service.resources import passages as passage_sets

__all__ = ["router"]

ERRORS = responses(413, 422, 429, 507)

router = APIRouter(tags=["maps"], route_class=MapRoute)


@router.post(
    "/maps",
    status_code=status.HTTP_201_CREATED,
    summary="Upload a map, and plan on it when start and goal are given",
    responses={200: {"model": MapPublic, "description": "The map was known already."}, **ERRORS},
    openapi_extra={
        "requestBody": {"content": {"multipart/form-data": {"schema": MULTIPART_FIELDS}}}
    },
)
async def create_map(body: MapCreate, engine: EngineDep, response: Response) -> MapPublic:
    """Upload a map as JSON `grid` (0 free, 1 blocked, -1 unknown; optional `resolution` and
    `origin`), Moving AI `rows`, or a rosbridge `occupancy_grid`; or as `multipart/form-data`
    with the parts `yaml` (a ROS map_server YAML) and `image` (its PGM/PNG/BMP), the other
    fields then as form fields. Its `map_id` hashes shape, occupancy, resolution and origin:
    the same whichever encoding was sent. `201` the first time, `200` after. With `start` and
    `goal` (cells or points in meters; and `preset`, `params`, `allow_narrow`, `robot_radius`,
    `unknown`) a plan is created too and returned under `plan`, as from `POST /plan`. An image
    whose header gives more than `PLANNER_MAX_MAP_CELLS` pixels is a `413`, before decoding."""
    view, created = await maps.add_map(engine, body)
    if not created:
        response.status_code = status.HTTP_200_OK
    return present.map_public(view)


@router.get("/maps/{map_id}", summary="A map's metadata", responses=responses(404, 422))
async def get_map(map_id: str, engine: EngineDep) -> MapPublic:
    """The `map_id`, `height`, `width`, `free_cells`, `occupied_cells`, `unknown_cells`,
    `resolution` and `origin` of an uploaded map, and a zoned map's `zones` (what
    `POST /maps/{map_id}/zones` applied; else null)."""
    return present.map_public(await maps.get_map(engine, map_id))


@router.get(
    "/maps/{map_id}/render.png",
    summary="A picture of the map and its analysis",
    **PNG_ROUTE,
)
async def render_map(
    map_id: str,
    engine: EngineDep,
    preset: Annotated[Preset, Query(description="Whose analysis to draw.")] = "wide",
    field: Annotated[
        Literal["clean"] | None, Query(description="Tint free cells by their clean penalty.")
    ] = None,
    cell: CellQuery = None,
    robot_radius: Annotated[
        float | None,
        Query(ge=0, le=100, description="The robot's radius in meters: draws its C-space margin."),
    ] = None,
    unknown: Annotated[
        Unknown | None, Query(description="How unknown cells count: `blocked` or `free`.")
    ] = None,
    passages: Annotated[
        bool,
        Query(description="Draw the narrow passages for `robot_radius`, labelled with width."),
    ] = False,
    crop: CropQuery = True,
) -> Response:
    """The map as the paper draws it: obstacles black, tight-tunnel cells orange (when the
    preset seals them), gates red; with `field=clean`, free cells tinted by their penalty. On a
    robot map, unknown cells grey-blue, the configuration space's margin for `robot_radius`
    pink, with a legend and a scale bar in meters. With `passages=true`, the narrow passages
    (as `GET /maps/{map_id}/passages` for `robot_radius`) violet, each labelled with its id and
    width. The picture holds the known part of the map (`crop=false`: all of it)."""
    overrides = {"robot_radius": robot_radius, "unknown": unknown}
    given = {name: value for name, value in overrides.items() if value is not None}
    png = await maps.render_map(engine, map_id, preset, field, cell, given, passages, crop)
    return Response(png, media_type="image/png")


@router.get(
    "/maps/{map_id}/passages",
    summary="The narrow passages of a map for a round robot",
    responses=responses(404, 422),
)
async def get_passages(
    map_id: str,
    engine: EngineDep,
    robot_radius: Annotated[
        float, Query(ge=0, le=100, description="The robot's radius in meters.")
    ],
    max_width: Annotated[
        float | None,
        Query(
            gt=0,
            le=1000,
            description="Narrow means at most this wide, meters (default `2 * robot_radius + "
            "0.3`); more than the robot's diameter.",
        ),
    ] = None,
) -> PassagesPublic:
    """The places where free space narrows below `max_width` between wider spaces and the robot
    still fits (width > 2 `robot_radius`): doors, gaps between shelves, narrow corridors. Each
    passage: `id`, its narrowest point `x`, `y` (meters, map frame), `width_m` there (center to
    center, to within one `resolution`) and `length_m` (how far the width stays below
    `max_width`). Unknown cells count as blocked. Computed once for a map, radius and
    `max_width`, then cached."""
    found = await passage_sets.map_passages(engine, map_id, robot_radius, max_width)
    return present.passages_public(found)

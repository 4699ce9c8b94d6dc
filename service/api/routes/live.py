"""``/maps/{map_id}/observations`` and ``/maps/{map_id}/live``: what the robots see, the
map's live layer shared by every plan on it (docs/live.md)."""

from __future__ import annotations

from fastapi import APIRouter, Response

from schemas import LiveMarksPublic, ObservationCreate, ObservationPublic
from service.api.deps import PNG_ROUTE, CellQuery, EngineDep, OrjsonRoute
from service.errors import responses
from service.resources import live

__all__ = ["router"]

router = APIRouter(tags=["live"], route_class=OrjsonRoute)


@router.post(
    "/maps/{map_id}/observations",
    summary="Report a laser scan: its returns mark the map's live layer, its rays clear it",
    responses=responses(404, 413, 422),
)
async def observe(map_id: str, body: ObservationCreate, engine: EngineDep) -> ObservationPublic:
    """A `sensor_msgs/LaserScan` (rosbridge JSON; a `null` range is no return) taken at
    `scan_pose` (`{x, y, yaw}`, the map frame), without a step: a robot or a fixed sensor that
    only reports. Each return in `[range_min, range_max)` marks its cell for
    `PLANNER_OBSTACLE_PERSISTENCE_SECONDS`; the cells along a ray before its return (or up to
    `range_max`) are cleared; returns within `robot_radius` of the pose are the robot's own
    body, ignored. The map's own blocked cells are never marked nor cleared. Every plan of
    this key on the map steps around the marks at once, on every replica. A map without a
    frame in meters (a plain grid) takes no scan (`422`)."""
    seen = await live.observe(
        engine, map_id, body.scan, body.scan_pose, robot_radius=body.robot_radius
    )
    return ObservationPublic(marked=seen.marked, cleared=seen.cleared, marks=seen.marks)


@router.get(
    "/maps/{map_id}/live", summary="The map's live marks now", responses=responses(404, 422)
)
async def get_live(map_id: str, engine: EngineDep) -> LiveMarksPublic:
    """The cells the robots' scans marked and no ray has cleared since, nor time lapsed
    (`PLANNER_OBSTACLE_PERSISTENCE_SECONDS`): `cells` (`[row, col]`) and `points` (their
    centers in meters)."""
    return LiveMarksPublic(**await live.live_view(engine, map_id))


@router.get("/maps/{map_id}/live.png", summary="A picture of the map's live marks", **PNG_ROUTE)
async def render_live(map_id: str, engine: EngineDep, cell: CellQuery = None) -> Response:
    """The map (blocked black, unknown grey-blue) with its live marks red."""
    return Response(await live.render_live(engine, map_id, cell), media_type="image/png")

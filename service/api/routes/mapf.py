"""``/maps/{map_id}/mapf``: offline multi-agent path finding on a map's roadmap."""

from __future__ import annotations

from fastapi import APIRouter

from schemas import MapfCreate, MapfPublic
from service.api.deps import EngineDep, OrjsonRoute
from service.errors import responses
from service.resources import mapf

__all__ = ["router"]

router = APIRouter(tags=["fleets"], route_class=OrjsonRoute)


@router.post(
    "/maps/{map_id}/mapf",
    summary="Plan agents together (multi-agent path finding)",
    responses=responses(404, 422),
)
async def solve(map_id: str, body: MapfCreate, engine: EngineDep) -> MapfPublic:
    """Plan `agents` (each a `start` and a `goal` cell) together on the map's roadmap for
    `robot_radius` (with radius 0 on a plain grid: its free cells, 4-connected, the Moving AI
    MAPF benchmark's graph): moves and waits, never two agents at one node, never a swap, agents
    staying at their goals. The solver is LaCAM with PIBT (complete), within `time_limit_s`:
    `solved` false and `status` `timeout` or `unsolvable` when it finds no plan."""
    solution, graph = await mapf.solve_mapf(engine, map_id, body)
    return MapfPublic(
        solved=solution.solved,
        status=solution.status,
        paths=mapf.paths_of(solution, graph),
        makespan=solution.makespan,
        sum_of_costs=solution.sum_of_costs,
        lower_bound=solution.lower_bound,
        solve_ms=solution.solve_ms,
    )

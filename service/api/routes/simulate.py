"""``/maps/{map_id}/simulate``: the paper's experiment, one seeded episode."""

from __future__ import annotations

from fastapi import APIRouter

from schemas import SimulationCreate, SimulationPublic
from service.api import present
from service.api.deps import EngineDep, OrjsonRoute
from service.errors import responses
from service.resources import simulation

__all__ = ["router"]

router = APIRouter(tags=["simulation"], route_class=OrjsonRoute)


@router.post(
    "/maps/{map_id}/simulate",
    summary="Run one episode among randomly moving obstacles",
    responses=responses(404, 413, 422),
)
async def simulate(map_id: str, body: SimulationCreate, engine: EngineDep) -> SimulationPublic:
    """Plan, then run a whole episode among `dynamic_count` obstacles that each step move to a
    random free neighbouring cell (seeded by `seed`: reproducible). Returns the robot's
    `trajectory` and the paper's metrics, plus clearance, collisions (0 for `wide` and
    `shortest`) and timings."""
    return present.simulation_public(await simulation.simulate(engine, map_id, body))

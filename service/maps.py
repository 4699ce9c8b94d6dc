"""Maps: decode an upload, keep it by its content hash, describe it, draw it."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Literal

import planner
from schemas import MapCreate, PlanCreate
from service import plans
from service.engine import Engine, cell_size
from service.errors import TooLarge
from service.stores import Grid

__all__ = ["MapView", "add_map", "get_map", "map_id_of", "render_map"]


@dataclass(frozen=True, slots=True)
class MapView:
    """A stored map, and the plan made with its upload when one was asked for."""

    map_id: str
    grid: Grid
    plan: plans.PlanView | None = None


def map_id_of(grid: Grid) -> str:
    """The hex SHA-256 of a map's shape and cells: the same for every encoding of one map."""
    h, w = grid.shape
    return hashlib.sha256(f"{h}x{w}:".encode() + grid.tobytes()).hexdigest()


async def add_map(engine: Engine, body: MapCreate) -> tuple[MapView, bool]:
    """Keep the map (True when new); plan on it too when the body has a start and a goal."""
    grid = await engine.pool.run(_decode, body, engine.settings.max_map_cells)
    map_id = map_id_of(grid)
    created = await engine.store.put_map(map_id, grid)
    plan = None
    if body.start is not None and body.goal is not None:
        request = PlanCreate(
            map_id=map_id,
            start=body.start,
            goal=body.goal,
            preset=body.preset,
            params=body.params,
            allow_narrow=body.allow_narrow,
        )
        plan = await plans.create_plan(engine, request)
    return MapView(map_id, grid, plan), created


async def get_map(engine: Engine, map_id: str) -> MapView:
    return MapView(map_id, await engine.grid(map_id))


async def render_map(
    engine: Engine, map_id: str, preset: str, field: Literal["clean"] | None, cell: int | None
) -> bytes:
    analysis, _ = await engine.analysis(map_id, planner.resolve_params(preset))
    size = cell_size(analysis.shape, cell)
    return await engine.pool.run(planner.render_map, analysis, field=field, cell=size)


def _decode(body: MapCreate, limit: int) -> Grid:
    if body.rows is not None:
        name, height, width = "rows", len(body.rows), len(body.rows[0]) if body.rows else 0
    else:
        assert body.grid is not None
        name, height, width = "grid", len(body.grid), len(body.grid[0]) if body.grid else 0
    # Checked before numpy sees the cells: a map too large is refused without copying it.
    if height * width > limit:
        msg = f"a {height} x {width} map has {height * width} cells; the limit is {limit}"
        raise TooLarge(msg, field=name)
    if body.rows is not None:
        return planner.parse_rows(body.rows)
    return planner.as_grid(body.grid)

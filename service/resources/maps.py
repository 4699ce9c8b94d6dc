"""Maps: decode an upload (grid, rows, OccupancyGrid, or ROS YAML + image), keep it by its
content hash, describe it, draw it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import planner
from schemas import MapCreate, PlanCreate
from service.errors import TooLarge
from service.resources import passages, plans
from service.work.engine import Engine
from service.work.pictures import cell_size

__all__ = ["MapView", "add_map", "get_map", "json_cells_message", "render_map"]


@dataclass(frozen=True, slots=True)
class MapView:
    """A stored map, and the plan made with its upload when one was asked for."""

    map_id: str
    robot_map: planner.RobotMap
    plan: plans.PlanView | None = None


async def add_map(engine: Engine, body: MapCreate) -> tuple[MapView, bool]:
    """Keep the map (True when new); plan on it too when the body has a start and a goal."""
    settings = engine.settings
    robot_map = await engine.pool.run(
        _decode, body, settings.max_map_cells, settings.max_json_map_cells
    )
    map_id = robot_map.map_id
    created = await engine.store.put_map(map_id, robot_map)
    engine.remember(map_id, robot_map)
    plan = None
    if body.start is not None and body.goal is not None:
        # The upload carries every field of a plan's request but the map's id.
        asked = {name: getattr(body, name) for name in PlanCreate.model_fields if name != "map_id"}
        request = PlanCreate(map_id=map_id, **asked)
        plan = await plans.create_plan(engine, request)
    return MapView(map_id, robot_map, plan), created


async def get_map(engine: Engine, map_id: str) -> MapView:
    return MapView(map_id, await engine.robot_map(map_id))


async def render_map(
    engine: Engine,
    map_id: str,
    preset: str,
    field: Literal["clean"] | None,
    cell: int | None,
    overrides: dict[str, Any],
    with_passages: bool = False,
    crop: bool = True,
) -> bytes:
    await engine.require_map(map_id)
    params = planner.resolve_params(preset, **overrides)
    analysis, _ = await engine.analysis(map_id, params)
    size = cell_size(analysis.shape, cell)
    found: tuple[planner.Passage, ...] = ()
    if with_passages:
        found = (await passages.map_passages(engine, map_id, params.robot_radius)).passages
    return await engine.pool.run(
        planner.render_map, analysis, field=field, cell=size, passages=found, crop=crop
    )


def _too_large(name: str, height: int, width: int, limit: int) -> None:
    if height * width > limit:
        msg = f"a {height} x {width} map has {height * width} cells; the limit is {limit}"
        raise TooLarge(msg, field=name)


def json_cells_message(cells: str, limit: int) -> str:
    """Why a map sent as JSON numbers is too large, and how to send it."""
    return (
        f"map: a `grid` or `occupancy_grid` of {cells} cells; PLANNER_MAX_JSON_MAP_CELLS is "
        f"{limit} (JSON numbers are slow to parse): send a larger map as Moving AI `rows`, or "
        "as an image with its YAML (multipart/form-data)"
    )


def _too_many_numbers(name: str, cells: int, limit: int) -> None:
    if cells > limit:
        raise TooLarge(json_cells_message(str(cells), limit), field=name)


def _decode(body: MapCreate, limit: int, json_limit: int) -> planner.RobotMap:
    # Every size is checked before numpy sees the cells: a map too large is refused without
    # copying it (an image, from its header, before its pixels are decoded).
    if body.yaml is not None:
        assert body.image is not None
        meta = planner.parse_map_yaml(body.yaml)
        width, height = planner.image_size(body.image)
        _too_large("image", height, width, limit)
        return planner.decode_map_image(body.image, meta)
    if body.occupancy_grid is not None:
        info = body.occupancy_grid.get("info")
        if isinstance(info, Mapping):
            w, h = info.get("width"), info.get("height")
            if isinstance(w, int) and isinstance(h, int):
                _too_large("occupancy_grid", h, w, limit)
                _too_many_numbers("occupancy_grid", h * w, json_limit)
        return planner.occupancy_grid_map(body.occupancy_grid)
    frame: dict[str, Any] = {}
    if body.resolution is not None:
        frame["resolution"] = body.resolution
    if body.origin is not None:
        frame["origin"] = body.origin
    if body.rows is not None:
        height, width = len(body.rows), len(body.rows[0]) if body.rows else 0
        _too_large("rows", height, width, limit)
        return planner.grid_map(planner.parse_rows(body.rows), name="rows", **frame)
    assert body.grid is not None
    height, width = len(body.grid), len(body.grid[0]) if body.grid else 0
    _too_large("grid", height, width, limit)
    _too_many_numbers("grid", height * width, json_limit)
    return planner.grid_map(body.grid, **frame)

"""A map's narrow passages for a robot (computed in the pool, cached by map, radius and
max_width), and what a plan's preview says of them: the narrowest point its path crosses and
the passages it goes through."""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass
from typing import Any

import planner
from planner.analysis.passages import MAX_WIDTH_SLACK
from service.errors import TooLarge
from service.tenants import scoped
from service.work.engine import Engine

__all__ = [
    "MAX_PASSAGE_CELLS",
    "PassageSet",
    "crossed",
    "crossings",
    "map_passages",
    "passages_key",
]

PASSAGE_BYTES = 200
"""What a passage holds besides its cells' array, charged to the cache."""


@dataclass(frozen=True, slots=True)
class PassageSet:
    """A map's passages for one robot radius and ``max_width`` (meters), as cached."""

    passages: tuple[planner.Passage, ...]
    robot_radius: float
    max_width: float

    @property
    def nbytes(self) -> int:
        return sum(p.cells.nbytes + PASSAGE_BYTES for p in self.passages) + PASSAGE_BYTES


def passages_key(map_id: str, robot_radius: float, max_width: float) -> Hashable:
    """The cache key of a map's passages (the map id is its content's hash), the tenant's."""
    return ("passages", scoped(map_id), float(robot_radius), float(max_width))


async def map_passages(
    engine: Engine, map_id: str, robot_radius: float, max_width: float | None = None
) -> PassageSet:
    """The map's passages for a robot of ``robot_radius`` meters (``max_width`` by default
    ``2 * robot_radius + 0.3``); ``NotFound`` for an unknown map, ``InvalidInput`` naming the
    parameter for bad ones."""
    width = 2 * robot_radius + MAX_WIDTH_SLACK if max_width is None else max_width
    await engine.require_map(map_id)

    async def compute() -> PassageSet:
        robot_map = await engine.robot_map(map_id)
        height, width_cells = robot_map.shape
        if height * width_cells > MAX_PASSAGE_CELLS:
            msg = (
                f"map_id: passages are found on maps of at most {MAX_PASSAGE_CELLS} cells "
                f"(2048 x 2048); this map has {height} x {width_cells}"
            )
            raise TooLarge(msg, field="map_id")
        found = await engine.pool.run(planner.find_passages, robot_map, robot_radius, width)
        return PassageSet(found, float(robot_radius), float(width))

    value, _ = await engine.cache.get_or_compute(passages_key(map_id, robot_radius, width), compute)
    return value


MAX_PASSAGE_CELLS = 2048 * 2048
"""The largest map whose passages are found (``413`` beyond; a plan's preview then names none):
finding them takes seconds and hundreds of megabytes a few million cells."""


async def crossings(engine: Engine, map_id: str, plan: planner.Plan) -> dict[str, Any]:
    """What a plan's record keeps for its preview: ``narrowest`` (``[x, y, width_m]``) and
    ``passages`` (the ids it crosses, for its ``robot_radius`` and the default ``max_width``);
    both None on a plain grid (cells without meters)."""
    height, width = plan.analysis.shape
    if plan.analysis.plain or plan.analysis.cspace is None or height * width > MAX_PASSAGE_CELLS:
        return {"narrowest": None, "passages": None}
    found = await map_passages(engine, map_id, plan.params.robot_radius)
    cspace, frame, path = plan.analysis.cspace, plan.analysis.frame, plan.path

    def cross() -> dict[str, Any]:
        x, y, width = planner.path_narrowest(cspace, frame, path)
        ids = planner.crossed_passages(found.passages, path, frame.shape)
        return {"narrowest": [x, y, width], "passages": list(ids)}

    return await engine.pool.run(cross)


async def crossed(
    engine: Engine, record: dict[str, Any], plan: planner.Plan
) -> tuple[planner.Passage, ...]:
    """The passages a stored plan crosses (its record's ids), to draw them; none on a plain
    grid or for a record from before passages."""
    ids = record.get("passages")
    if not ids:
        return ()
    found = await map_passages(engine, record["map_id"], plan.params.robot_radius)
    return tuple(p for p in found.passages if p.id in set(ids))

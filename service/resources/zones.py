"""Zones: a stored map zoned (keepout polygons or a keepout filter mask blocked, speed zones
kept) into a new stored map, from the base map's stored cells."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

import planner
from planner.maps.zoning import check_mask_frame
from schemas import ZonesCreate
from service.resources.maps import MapView
from service.work.engine import Engine

__all__ = ["add_zones"]


async def add_zones(engine: Engine, map_id: str, body: ZonesCreate) -> tuple[MapView, bool]:
    """The map ``map_id`` zoned as ``body`` says, kept (True when new); ``NotFound`` when the
    map is unknown."""
    base = await engine.robot_map(map_id)
    zoned = await engine.pool.run(_zone, base, body)
    created = await engine.store.put_map(zoned.map_id, zoned)
    engine.remember(zoned.map_id, zoned)
    return MapView(zoned.map_id, zoned), created


def _zone(base: planner.RobotMap, body: ZonesCreate) -> planner.RobotMap:
    keepout = [[(p.x, p.y) for p in polygon] for polygon in body.keepout]
    speed: list[dict[str, Any]] = [
        {"polygon": [(p.x, p.y) for p in zone.polygon], "max_speed": zone.max_speed}
        for zone in body.speed
    ]
    mask = None if body.yaml is None else _mask(base.frame, body.yaml, body.image)
    return planner.zone_map(base, keepout=keepout, speed=speed, mask=mask)


def _mask(frame: planner.MapFrame, yaml: bytes, image: bytes | None) -> npt.NDArray[np.bool_]:
    """A keepout filter mask's cells, its size (from the image's header), resolution and origin
    (from its YAML) checked before its pixels are decoded."""
    assert image is not None
    meta = planner.parse_map_yaml(yaml)
    width, height = planner.image_size(image)
    check_mask_frame((height, width), meta.resolution, meta.origin, frame)
    return planner.keepout_mask(planner.decode_map_image(image, meta), frame)

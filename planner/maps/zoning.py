"""Zoning a map (docs/zones.md): a new map whose cells are the base map's with every keepout cell
blocked, and which keeps its zones; from polygons in meters or a Nav2 keepout filter mask.

>>> from planner.maps.robot_maps import grid_map
>>> base = grid_map([[0] * 4] * 3, resolution=0.5)
>>> zoned = zone_map(base, keepout=[[(0.0, 0.0), (1.0, 0.0), (1.0, 0.6)]])
>>> (zoned.occupancy == 100).astype(int).tolist()
[[0, 0, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0]]
>>> zoned.zones.base_map_id == base.map_id, zoned.map_id != base.map_id
(True, True)
"""

from __future__ import annotations

import hashlib
import math
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.errors import InvalidInput
from planner.maps.frames import MapFrame
from planner.maps.robot_maps import RobotMap
from planner.maps.zones import KeepoutMask, Zones, check_zones, keepout_cells

__all__ = ["MASK_OCCUPIED", "check_mask_frame", "keepout_mask", "zone_map"]

MASK_OCCUPIED = 65
"""A keepout mask's cell of at least this occupancy (percent) is keepout: map_server's
``occupied_thresh`` decides which pixels reach 100."""

BLOCKED = 100


def keepout_mask(mask: RobotMap, frame: MapFrame) -> npt.NDArray[np.bool_]:
    """The keepout cells of a Nav2 keepout filter ``mask`` (a map_server map), which must have
    ``frame``'s size, resolution and origin: its cells of occupancy ``MASK_OCCUPIED`` or
    more."""
    check_mask_frame(mask.shape, mask.resolution, mask.origin, frame)
    out: npt.NDArray[np.bool_] = mask.occupancy >= MASK_OCCUPIED
    return out


def check_mask_frame(
    shape: tuple[int, int], resolution: float, origin: Any, frame: MapFrame
) -> None:
    """``InvalidInput`` naming the field unless a keepout mask of ``shape`` (rows, columns),
    ``resolution`` and ``origin`` lies on ``frame``: checked from the image's header and the
    YAML before a pixel is decoded."""
    (h, w), (H, W) = shape, frame.shape
    if (h, w) != (H, W):
        msg = f"image: the mask is {w} x {h} cells; the map is {W} x {H}"
        raise InvalidInput(msg, field="image")
    if not math.isclose(resolution, frame.resolution, rel_tol=1e-9, abs_tol=0.0):
        msg = (
            f"yaml.resolution: the mask's is {resolution:g} m; the map's is {frame.resolution:g} m"
        )
        raise InvalidInput(msg, field="yaml.resolution")
    tolerance = (1e-6, 1e-6, 1e-9)  # meters, meters, radians
    if any(abs(a - b) > t for a, b, t in zip(origin, frame.origin, tolerance, strict=True)):
        msg = f"yaml.origin: the mask's is {list(origin)}; the map's is {list(frame.origin)}"
        raise InvalidInput(msg, field="yaml.origin")


def zone_map(
    base: RobotMap,
    *,
    keepout: Any = (),
    speed: Any = (),
    mask: npt.NDArray[np.bool_] | None = None,
) -> RobotMap:
    """``base`` zoned: keepout polygons (lists of ``(x, y)`` or ``{"x", "y"}`` in meters) and
    the cells of a keepout ``mask`` (:func:`keepout_mask`) blocked (occupancy 100), speed zones
    (``{"polygon", "max_speed"}``) kept for the poses. Its zones are ``base``'s and these (at
    most :data:`~planner.maps.zones.MAX_ZONES` in all, and
    :data:`~planner.maps.zones.MAX_ZONE_POINTS` points); its id hashes its cells and zones,
    ``base``'s id among them."""
    polygons, zones = check_zones(
        keepout, speed, carried=base.zones, masks=0 if mask is None else 1
    )
    blocked = keepout_cells(base.frame, polygons)
    masks: tuple[KeepoutMask, ...] = ()
    if mask is not None:
        bits = np.ascontiguousarray(mask, dtype=np.bool_)
        blocked |= bits
        digest = hashlib.sha256(bits.view(np.uint8).tobytes()).hexdigest()
        masks = (KeepoutMask(int(np.count_nonzero(bits)), digest),)
    occupancy = base.occupancy.copy()
    occupancy[blocked] = BLOCKED
    before = base.zones or Zones(base_map_id="")
    applied = Zones(
        base_map_id=base.map_id,
        keepout=before.keepout + polygons,
        speed=before.speed + zones,
        keepout_masks=before.keepout_masks + masks,
    )
    return RobotMap(occupancy, base.frame, applied)

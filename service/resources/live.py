"""The live layer (docs/live.md): scans traced into the map's marks, shared by every plan of
the tenant on the map through the store; a step's scan, the marks it steps around, and the
layer read and drawn."""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

import planner
from planner import quote
from schemas import LaserScan, Point, ScanPose, StepCreate
from service.stores.live import Seen
from service.tenants import scoped
from service.work.engine import Engine
from service.work.pictures import cell_size, frame_map

__all__ = [
    "MARKS_ON_LOOP",
    "MapSight",
    "Observed",
    "live_cells",
    "live_view",
    "observe",
    "render_live",
    "step_marks",
    "with_marks",
]


@dataclass(frozen=True, slots=True)
class MapSight:
    """What a scan is traced on: the map's frame and its own blocked cells (never marked or
    cleared), cached per map."""

    frame: planner.MapFrame
    blocked: npt.NDArray[np.bool_]

    @property
    def nbytes(self) -> int:
        return int(self.blocked.nbytes) + 200


@dataclass(frozen=True, slots=True)
class Observed:
    """What one scan did: cells it marked and cleared, and the map's marks after it."""

    marked: int
    cleared: int
    marks: int


async def sight(engine: Engine, map_id: str, *, known: bool = False) -> MapSight:
    """The map's frame and blocked cells (``NotFound`` for an unknown map; unless ``known``,
    the store is asked whether it holds the map now, as what is cached of a map outlives it)."""
    if not known:
        await engine.require_map(map_id)

    async def compute() -> MapSight:
        robot_map = await engine.robot_map(map_id)
        return MapSight(robot_map.frame, robot_map.blocked())

    key: Hashable = ("sight", scoped(map_id))
    value, _ = await engine.cache.get_or_compute(key, compute)
    return value


async def observe(
    engine: Engine,
    map_id: str,
    scan: LaserScan,
    pose: ScanPose,
    *,
    robot: tuple[float, float] | None = None,
    robot_radius: float = 0.0,
    known: bool = False,
) -> Observed:
    """Trace ``scan`` taken at ``pose`` on the map and update its live layer (one store call).
    A map without a frame in meters (a plain grid) takes no scan: ``InvalidInput`` on
    ``scan``. ``known``: a step's scan, whose plan's map the step's write checks."""
    seen = await sight(engine, map_id, known=known)
    if seen.frame.is_default:
        msg = (
            f"scan: map {quote(map_id)} has no frame in meters (a plain grid, 1 m a cell); "
            "scans are taken on robot maps (a ROS map, an OccupancyGrid, or a grid with its "
            "resolution and origin)"
        )
        raise planner.InvalidInput(msg, field="scan")
    laser = planner.LaserScan(
        scan.angle_min,
        scan.angle_increment,
        scan.range_min,
        scan.range_max,
        np.array(scan.ranges, dtype=np.float64),  # null: NaN, no return
    )
    traced = await engine.pool.run_step(
        planner.trace_scan,
        seen.frame,
        seen.blocked,
        laser,
        (pose.x, pose.y, pose.yaw),
        robot=robot,
        robot_radius=robot_radius,
    )
    seconds = engine.settings.obstacle_persistence_seconds
    marks = await engine.store.observe(map_id, Seen(traced, seen.frame.shape[1], seconds))
    cleared = int(np.count_nonzero(traced.cleared))
    return Observed(int(traced.marked.size), cleared, marks)


async def live_cells(engine: Engine, map_id: str) -> npt.NDArray[np.int64]:
    """The map's marks now, as ``(n, 2)`` ``[row, col]`` cells."""
    return _cells(await engine.store.live_marks(map_id), (await sight(engine, map_id)).frame)


def _cells(flat: npt.NDArray[np.int64], frame: planner.MapFrame) -> npt.NDArray[np.int64]:
    width = frame.shape[1]
    return np.stack([flat // width, flat % width], axis=1)


async def live_view(engine: Engine, map_id: str) -> dict[str, Any]:
    """The map's marks as ``GET /maps/{map_id}/live`` answers them."""
    frame = (await sight(engine, map_id)).frame
    cells = _cells(await engine.store.live_marks(map_id), frame)
    return {
        "map_id": map_id,
        "persistence_seconds": engine.settings.obstacle_persistence_seconds,
        "cells": cells.tolist(),
        "points": frame.centers(cells).tolist(),
    }


async def step_marks(
    engine: Engine, map_id: str, plan: planner.Plan, body: StepCreate, here: tuple[int, int]
) -> tuple[npt.NDArray[np.int64], str]:
    """A step's part of the live layer: its ``scan`` added first (taken at ``scan_pose``, by
    default the step's ``position`` point and yaw), then the cells the map's marks block for
    this robot, with the digest of the marks, which the step's write checks (the marks as the
    store knows them: no store call of their own; none on a plain grid, which takes no scan):
    each mark's cell widened by the robot's radius (as a circle obstacle is), less the marks on
    the robot's own body (within its radius and a cell of where it is, ``here`` or its reported
    point): another robot's scan of it is no obstacle to it."""
    frame = plan.analysis.frame
    radius = plan.params.robot_radius
    point = body.position if isinstance(body.position, Point) else None
    center = (point.x, point.y) if point is not None else tuple(frame.centers([here])[0])
    if body.scan is not None:
        pose = body.scan_pose
        if pose is None and point is not None and point.yaw is not None:
            pose = ScanPose(x=point.x, y=point.y, yaw=point.yaw)
        if pose is None:
            msg = (
                "scan_pose: a scan needs the sensor's pose; give scan_pose {x, y, yaw}, or the "
                "step's position as a point with its yaw"
            )
            raise planner.InvalidInput(msg, field="scan_pose")
        robot = (float(center[0]), float(center[1]))
        await observe(engine, map_id, body.scan, pose, robot=robot, robot_radius=radius, known=True)
    if frame.is_default:  # a plain grid takes no scan: no marks to read
        return np.zeros((0, 2), dtype=np.int64), ""
    known = await engine.store.known_marks(map_id)
    return await _blocked(engine, frame, _cells(known.cells, frame), center, radius), known.digest


async def _blocked(
    engine: Engine,
    frame: planner.MapFrame,
    cells: npt.NDArray[np.int64],
    center: Any,
    radius: float,
) -> npt.NDArray[np.int64]:
    """The cells ``cells`` (marks) block for a robot of ``radius`` at ``center``, less those on
    its own body."""
    if not len(cells):
        return cells
    points = frame.centers(cells)
    own = np.hypot(*(points - np.asarray(center)).T) <= radius + frame.resolution
    # Each mark as the circle of its cell, widened by the robot's radius as a circle is.
    half = frame.resolution / 2
    circles = [{"x": x, "y": y, "radius": half} for x, y in points[~own].tolist()]
    if not circles:
        return cells[:0]
    if len(circles) <= MARKS_ON_LOOP:
        return planner.circle_cells(frame_map(frame), circles, robot_radius=radius)
    return await engine.pool.run_step(
        planner.circle_cells, frame_map(frame), circles, robot_radius=radius
    )


MARKS_ON_LOOP = 64
"""Marks a step widens on the event loop (a fraction of a millisecond); more, on a step
worker."""


def with_marks(obstacles: Any, marks: npt.NDArray[np.int64]) -> Any:
    """A step's obstacles and the live layer's marks, as one input: the marks are obstacles
    like the client's cells (kept as given when there are none)."""
    if not len(marks):
        return obstacles
    given = np.asarray(obstacles, dtype=np.int64).reshape(-1, 2)
    return np.concatenate([given, marks])


async def render_live(engine: Engine, map_id: str, cell: int | None) -> bytes:
    """The map drawn with its live marks (red)."""
    robot_map = await engine.robot_map(map_id)
    marks = await live_cells(engine, map_id)
    size = cell_size(robot_map.shape, cell)
    return await engine.pool.run(planner.render_live, robot_map, marks, cell=size)

"""What the clients' calls send besides their positional arguments (None: not sent, the
server's default), as typed dicts; a test checks them against the request models of
``schemas``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Required, TypedDict

__all__ = [
    "CellIn",
    "MapfFields",
    "PlanFields",
    "PointIn",
    "RouteFields",
    "SimulateFields",
    "StepFields",
    "UploadMapFields",
    "ZonesFields",
]

CellIn = Sequence[int] | Mapping[str, float]
"""A cell ``[row, col]``, or a point ``{"x": ..., "y": ...}`` in meters (with an optional
``"yaw"`` in radians) where the API takes one."""
PointIn = Sequence[float] | Mapping[str, float]
"""A polygon's point: ``{"x": ..., "y": ...}`` or ``(x, y)``, meters."""


class PlanFields(TypedDict, total=False):
    """``plan``'s options, ``schemas.plans.PlanOptions``: the preset, overrides, the robot."""

    preset: str | None
    params: Mapping[str, Any] | None
    allow_narrow: bool | None
    robot_radius: float | None
    footprint: Sequence[Sequence[float]] | None
    motion: str | None
    min_turning_radius: float | None
    unknown: str | None
    goal_tolerance: float | None


class RouteFields(PlanFields, total=False):
    """``plan``'s fields besides the ends: the options, the ``waypoints`` (cells or points)
    the path passes through, in order, the robot's ``fleet`` and the plan's ``name``."""

    waypoints: Sequence[CellIn] | None
    fleet: str | None
    name: str | None


class UploadMapFields(RouteFields, total=False):
    """``upload_map``'s fields: one map, its frame, and the plan's ends, waypoints and
    options."""

    grid: Sequence[Sequence[int]] | None
    rows: Sequence[str] | None
    occupancy_grid: Mapping[str, Any] | None
    yaml: str | Path | None
    resolution: float | None
    origin: Sequence[float] | None
    start: CellIn | None
    goal: CellIn | None


class ZonesFields(TypedDict, total=False):
    """``add_zones``'s fields, as ``schemas.ZonesCreate``: ``keepout`` polygons and ``speed``
    zones (``{"polygon", "max_speed"}``), points ``{"x", "y"}`` or pairs ``(x, y)`` in meters;
    or a keepout filter mask's ``yaml`` file (its image, which the YAML names, read beside
    it)."""

    keepout: Sequence[Sequence[PointIn]] | None
    speed: Sequence[Mapping[str, Any]] | None
    yaml: str | Path | None


class SimulateFields(PlanFields, total=False):
    """``simulate``'s fields besides the ends, as ``schemas.SimulationCreate``."""

    dynamic_count: Required[int]
    seed: Required[int]
    max_steps: int | None
    obstacle_motion: str | None


class StepFields(TypedDict, total=False):
    """``step``'s fields besides the obstacles: ``seq``, and where the robot really is."""

    seq: int | None
    position: CellIn | None
    scan: Mapping[str, Any] | None
    scan_pose: Mapping[str, float] | None


class MapfFields(TypedDict, total=False):
    """``mapf``'s fields besides the agents."""

    robot_radius: float | None
    time_limit_s: float | None
    preset: str | None

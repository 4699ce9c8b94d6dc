"""What the robots see (docs/live.md): a laser scan and the sensor's pose in a step or an
observation, and the map's live marks in answers."""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

from schemas.points import STRICT, XY, Cell

__all__ = [
    "MAX_RAYS",
    "LaserScan",
    "LiveMarksPublic",
    "ObservationCreate",
    "ObservationPublic",
    "ScanPose",
]

MAX_RAYS = 16384
"""Rays one scan holds at most (a 0.1° lidar has 3,600; a 0.025° one 14,400)."""

Finite = Annotated[float, Field(allow_inf_nan=False)]
Range = Annotated[float | None, Field(allow_inf_nan=False)]

EXAMPLE_SCAN: dict[str, Any] = {
    "angle_min": -1.5708,
    "angle_increment": 0.7854,
    "range_min": 0.1,
    "range_max": 12.0,
    "ranges": [2.5, None, 1.2, 1.25, None],
}


class LaserScan(BaseModel):
    """A ``sensor_msgs/LaserScan`` as rosbridge writes it: ray ``i`` points at
    ``angle_min + i * angle_increment`` radians from the sensor's heading; ``ranges`` in
    meters, ``null`` where no return came (rosbridge's NaN and inf). The message's other fields
    are taken and not used."""

    model_config = ConfigDict(**STRICT, json_schema_extra={"examples": [EXAMPLE_SCAN]})

    angle_min: Finite
    angle_increment: Finite = Field(description="Radians between rays; the span at most 2*pi.")
    range_min: Finite = Field(ge=0, le=1e5, description="Returns closer than this are ignored.")
    range_max: Finite = Field(
        gt=0,
        le=1e5,
        description="Rays with no return clear up to here (meters, at most 100 km); more than "
        "`range_min`.",
    )
    ranges: list[Range] = Field(min_length=1, max_length=MAX_RAYS)
    angle_max: Finite | None = None
    time_increment: Finite | None = None
    scan_time: Finite | None = None
    intensities: list[Range] = Field(default_factory=list, max_length=MAX_RAYS)
    header: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _consistent(self) -> LaserScan:
        if self.range_min >= self.range_max:
            msg = (
                f"scan.range_min {self.range_min!r} must be less than scan.range_max "
                f"{self.range_max!r}"
            )
            raise ValueError(msg)
        span = abs(self.angle_increment) * (len(self.ranges) - 1)
        if span > 2 * math.pi + 1e-9:
            msg = (
                f"scan.angle_increment {self.angle_increment!r} x {len(self.ranges) - 1} rays "
                f"spans {span:.6g} radians; a scan spans at most 2*pi"
            )
            raise ValueError(msg)
        return self


class ScanPose(BaseModel):
    """The sensor's pose in the map frame: ``x``, ``y`` in meters, ``yaw`` in radians."""

    model_config = ConfigDict(
        **STRICT, json_schema_extra={"examples": [{"x": 2.0, "y": 1.5, "yaw": 0.0}]}
    )

    x: Finite
    y: Finite
    yaw: Finite


class ObservationCreate(BaseModel):
    """A scan without a step: a robot or a fixed sensor that only reports what it sees."""

    model_config = ConfigDict(
        **STRICT,
        json_schema_extra={
            "examples": [{"scan": EXAMPLE_SCAN, "scan_pose": {"x": 2.0, "y": 1.5, "yaw": 0.0}}]
        },
    )

    scan: LaserScan
    scan_pose: ScanPose
    robot_radius: Finite = Field(
        default=0.0,
        ge=0,
        le=1e3,
        description="The reporting robot's radius (meters): returns within it of `scan_pose` "
        "are its own body, ignored.",
    )


class ObservationPublic(BaseModel):
    """What one scan did to the map's live layer."""

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"marked": 3, "cleared": 412, "marks": 17}]}
    )

    marked: int = Field(ge=0, description="Cells the scan's returns marked.")
    cleared: int = Field(ge=0, description="Cells the scan's rays crossed (and cleared).")
    marks: int = Field(ge=0, description="The map's live marks now, every robot's.")


class LiveMarksPublic(BaseModel):
    """The map's live layer now: the cells the robots' scans marked and not yet cleared or
    lapsed, as cells and as their centers in meters."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "map_id": "ab12...",
                    "persistence_seconds": 5.0,
                    "cells": [[12, 40]],
                    "points": [[2.025, 4.725]],
                }
            ]
        }
    )

    map_id: str
    persistence_seconds: float = Field(
        gt=0, description="How long a mark lasts unless a ray clears it first."
    )
    cells: list[Cell]
    points: list[XY] = Field(description="The cells' centers in the map frame, meters.")

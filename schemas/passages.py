"""Narrow passages: ``GET /maps/{map_id}/passages`` and a plan preview's ``narrowest``."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["NarrowestPublic", "PassagePublic", "PassagesPublic"]

EXAMPLE_PASSAGE: dict[str, Any] = {
    "id": 0,
    "x": 12.425,
    "y": 3.075,
    "width_m": 0.6,
    "length_m": 0.45,
}


class PassagePublic(BaseModel):
    """A place where free space narrows below ``max_width`` between wider spaces, the robot
    still fitting (width > 2 ``robot_radius``)."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_PASSAGE]})

    id: int = Field(ge=0, description="0.. in the order of the narrowest cell (row, then col).")
    x: float = Field(description="The narrowest point (a cell's center), meters, map frame.")
    y: float
    width_m: float = Field(
        gt=0,
        description="The width there, center to center: twice the distance to the nearest "
        "blocked cell's center (a 0.55 m door on a 0.05 m map: 0.60).",
    )
    length_m: float = Field(
        ge=0, description="How far along the passage the width stays below `max_width`."
    )


class PassagesPublic(BaseModel):
    """A map's narrow passages for a round robot."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [{"passages": [EXAMPLE_PASSAGE], "robot_radius": 0.2, "max_width": 0.7}]
        }
    )

    passages: list[PassagePublic]
    robot_radius: float = Field(ge=0, description="The robot's radius they are for, meters.")
    max_width: float = Field(gt=0, description="The width below which a place is narrow.")


class NarrowestPublic(BaseModel):
    """The narrowest point a path crosses: the center of its path cell nearest to a blocked
    cell, and the width there (twice that distance, center to center), meters."""

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"x": 12.425, "y": 3.075, "width_m": 0.6}]}
    )

    x: float
    y: float
    width_m: float = Field(ge=0)

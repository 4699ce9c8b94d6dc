"""The shapes of places in requests and answers: cells ``[row, col]``, points and poses in
meters, circles, and the unions of a cell with a point or a circle."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag

__all__ = [
    "COORDINATE_MAX",
    "STRICT",
    "UNION_TAGS",
    "XY",
    "Cell",
    "CellOrPoint",
    "Circle",
    "Obstacle",
    "Point",
    "Pose",
    "XYPublic",
]

STRICT = ConfigDict(extra="forbid", strict=True)
"""Every request model: an unknown field is refused (a typo such as ``obstacles`` for
``dynamic_obstacles`` must not pass silently), and no value is coerced: integers and cells are
JSON integers, never booleans, strings or floats."""

COORDINATE_MAX = 2**31 - 1
Coordinate = Annotated[int, Field(ge=0, le=COORDINATE_MAX)]
Cell = Annotated[list[Coordinate], Field(min_length=2, max_length=2, examples=[[0, 9]])]
"""A ``[row, col]`` cell, row 0 at the top."""

Meters = Annotated[float, Field(allow_inf_nan=False)]
XY = Annotated[list[float], Field(min_length=2, max_length=2, examples=[[1.25, 0.75]])]
"""An ``[x, y]`` point in the map frame, meters (in answers: a cell's center)."""


class Point(BaseModel):
    """A point in the map frame, in meters: it means the cell that contains it; as a plan's start
    or goal, the poses start or end there. ``yaw`` (radians, optional): a heading; the goal's is
    the last pose's yaw."""

    model_config = ConfigDict(
        **STRICT, json_schema_extra={"examples": [{"x": 1.2, "y": 0.4, "yaw": 1.5708}]}
    )

    x: Meters
    y: Meters
    yaw: float | None = Field(
        default=None,
        allow_inf_nan=False,
        description="A heading in radians (finite), counter-clockwise from the map's x axis.",
    )


class Pose(BaseModel):
    """A pose in the map frame: ``x``, ``y`` in meters, ``yaw`` in radians (the direction of
    travel)."""

    model_config = ConfigDict(json_schema_extra={"examples": [{"x": 0.5, "y": 4.5, "yaw": 0.0}]})

    x: float
    y: float
    yaw: float
    max_speed: float | None = Field(
        default=None,
        gt=0,
        exclude_if=lambda v: v is None,
        description="Inside a speed zone (`POST /maps/{map_id}/zones`): the least `max_speed` "
        "(m/s) of the zones holding the pose; absent elsewhere.",
    )
    direction: int | None = Field(
        default=None,
        ge=-1,
        le=1,
        exclude_if=lambda v: v is None,
        description="With a footprint or a car motion: 1 when the robot drives forward to this "
        "pose, -1 in reverse (the first pose: the motion leaving it); absent otherwise.",
    )


class XYPublic(BaseModel):
    """A point in the map frame, meters."""

    x: float
    y: float


class Circle(BaseModel):
    """A round dynamic obstacle in meters: it blocks, for one step, every cell whose center is
    within ``radius + robot_radius`` of ``(x, y)``."""

    model_config = ConfigDict(
        **STRICT, json_schema_extra={"examples": [{"x": 1.2, "y": 0.4, "radius": 0.3}]}
    )

    x: Meters
    y: Meters
    radius: Meters = Field(ge=0, le=1e6)


def _cell_or_mapping(tag: str) -> Any:
    def pick(value: Any) -> str:
        return tag if isinstance(value, dict | BaseModel) else "cell"

    return Discriminator(pick)


CellOrPoint = Annotated[
    Annotated[list[Coordinate], Field(min_length=2, max_length=2), Tag("cell")]
    | Annotated[Point, Tag("point")],
    _cell_or_mapping("point"),
    Field(examples=[[0, 9], {"x": 1.2, "y": 0.4}]),
]
"""A ``[row, col]`` cell or a point ``{"x", "y"}`` in meters."""

Obstacle = Annotated[
    Annotated[list[Coordinate], Field(min_length=2, max_length=2), Tag("cell")]
    | Annotated[Circle, Tag("circle")],
    _cell_or_mapping("circle"),
]
"""A dynamic obstacle: a ``[row, col]`` cell or a circle ``{"x", "y", "radius"}`` in meters."""

UNION_TAGS = frozenset({"cell", "point", "circle"})
"""The tags of those unions: error locations leave them out (``start[0]``, not
``start.cell[0]``)."""

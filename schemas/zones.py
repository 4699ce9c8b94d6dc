"""Zones: ``POST /maps/{map_id}/zones`` (keepout and speed polygons, or a keepout filter mask)
and the zones ``GET /maps/{map_id}`` lists."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar

from pydantic import BaseModel, ConfigDict, Field, model_validator

from schemas.parts import MapParts, multipart_form
from schemas.points import STRICT, XYPublic

__all__ = [
    "ZONES_MULTIPART",
    "KeepoutMaskPublic",
    "SpeedZoneCreate",
    "SpeedZonePublic",
    "ZonePoint",
    "ZonesCreate",
    "ZonesPublic",
]

POLYGON_POINTS_MAX = 1000
ZONES_MAX = 256
COORDINATE_MAX = 1e9


class ZonePoint(BaseModel):
    """A polygon's vertex in the map frame, meters."""

    model_config = STRICT

    x: float = Field(ge=-COORDINATE_MAX, le=COORDINATE_MAX, allow_inf_nan=False)
    y: float = Field(ge=-COORDINATE_MAX, le=COORDINATE_MAX, allow_inf_nan=False)


Polygon = Annotated[
    list[ZonePoint],
    Field(
        min_length=3,
        max_length=POLYGON_POINTS_MAX,
        description="At least three points `{x, y}` in meters, the map frame, in order (the "
        "last joined to the first); a simple polygon (no edge crossing or touching another).",
    ),
]

_SQUARE: list[Any] = [
    {"x": 1.0, "y": 1.0},
    {"x": 2.0, "y": 1.0},
    {"x": 2.0, "y": 2.0},
    {"x": 1.0, "y": 2.0},
]
_STRIP: list[Any] = [
    {"x": 0.0, "y": 3.0},
    {"x": 4.0, "y": 3.0},
    {"x": 4.0, "y": 3.5},
    {"x": 0.0, "y": 3.5},
]


class SpeedZoneCreate(BaseModel):
    """A speed zone: a polygon where the robot drives at ``max_speed`` m/s at most."""

    model_config = STRICT

    polygon: Polygon
    max_speed: float = Field(gt=0, le=100, allow_inf_nan=False, description="m/s.")


ZONES_MULTIPART = multipart_form(
    yaml="The keepout filter mask's map_server YAML (the map's frame).",
    image="Its PGM/PNG/BMP, the map's size: an occupied cell is keepout.",
    keepout="JSON list of polygons, as in JSON bodies.",
    speed="JSON list of speed zones.",
)
"""The ``multipart/form-data`` form of ``POST /maps/{map_id}/zones``, for ``/docs``."""


class ZonesCreate(MapParts):
    """Zones to apply to a map: ``keepout`` polygons, ``speed`` zones, or (multipart) a keepout
    filter mask as the parts ``yaml`` and ``image``; at least one of them."""

    model_config = ConfigDict(
        **STRICT,
        json_schema_extra={
            "examples": [
                {"keepout": [_SQUARE], "speed": [{"polygon": _STRIP, "max_speed": 0.3}]},
            ]
        },
    )

    keepout: list[Polygon] = Field(
        default_factory=list,
        max_length=ZONES_MAX,
        description="Polygons the robot never enters: every cell whose center one holds is "
        "blocked.",
    )
    speed: list[SpeedZoneCreate] = Field(
        default_factory=list,
        max_length=ZONES_MAX,
        description="Polygons where poses carry `max_speed`.",
    )
    parts_of: ClassVar[str] = "a keepout mask"

    @model_validator(mode="after")
    def _at_least_one(self) -> ZonesCreate:
        if (self.yaml is None) != (self.image is None):
            missing = "image" if self.image is None else "yaml"
            raise ValueError(
                f"a keepout mask needs both parts 'yaml' and 'image'; {missing!r} is missing"
            )
        if not self.keepout and not self.speed and self.yaml is None:
            raise ValueError("give 'keepout', 'speed', or a keepout mask ('yaml' and 'image')")
        if len(self.keepout) + len(self.speed) > ZONES_MAX:
            raise ValueError(f"at most {ZONES_MAX} polygons, keepout and speed together")
        return self


class SpeedZonePublic(BaseModel):
    """A speed zone of a map."""

    polygon: list[XYPublic]
    max_speed: float = Field(gt=0, description="m/s.")


class KeepoutMaskPublic(BaseModel):
    """A keepout filter mask applied to a map."""

    cells: int = Field(ge=0, description="The cells it marks keepout.")
    sha256: str = Field(description="Hex SHA-256 of its keepout cells, one byte a cell.")


class ZonesPublic(BaseModel):
    """The zones of a zoned map, its base map's own first."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "base_map_id": "0f" * 32,
                    "keepout": [_SQUARE],
                    "speed": [{"polygon": _STRIP, "max_speed": 0.3}],
                    "keepout_masks": [],
                }
            ]
        }
    )

    base_map_id: str = Field(description="The map the zones were applied to.")
    keepout: list[list[XYPublic]] = Field(description="Keepout polygons.")
    speed: list[SpeedZonePublic] = Field(description="Speed zones.")
    keepout_masks: list[KeepoutMaskPublic] = Field(description="Keepout filter masks.")

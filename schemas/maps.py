"""Maps: ``POST /maps`` (with an optional first plan) and ``GET /maps/{map_id}``."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

from schemas.examples import EXAMPLE_MAP, EXAMPLE_MAP_ID, EXAMPLE_PLAN
from schemas.fleet_names import FleetName
from schemas.parts import MapParts, multipart_form
from schemas.plans import (
    PlanName,
    PlanOptions,
    PlanPublic,
    Waypoints,
)
from schemas.points import STRICT, CellOrPoint
from schemas.zones import ZonesPublic

__all__ = ["MULTIPART_FIELDS", "MapCreate", "MapEncoding", "MapPublic"]

EXAMPLE_OCCUPANCY_GRID: dict[str, Any] = {
    "info": {
        "resolution": 0.5,
        "width": 3,
        "height": 2,
        "origin": {
            "position": {"x": -1.0, "y": 0.0, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        },
    },
    "data": [0, 0, 0, 0, 100, -1],
}

MULTIPART_FIELDS = multipart_form(
    yaml="A map_server map YAML.",
    image="The PGM/PNG/BMP image it describes (the YAML's `image` is not read).",
    start='JSON: a cell `[r, c]` or `{"x", "y"}`.',
    goal="JSON, as `start`.",
    preset="A preset name, as in JSON bodies.",
    params="JSON object of parameter overrides.",
    allow_narrow="`true` or `false`.",
    robot_radius="Meters, e.g. `0.22`.",
    unknown="`blocked` or `free`.",
    waypoints="JSON list of cells or points.",
    fleet="The plan's fleet name.",
    name="The plan's name.",
)
"""The ``multipart/form-data`` form of ``POST /maps``, for ``/docs``: parts ``yaml`` and
``image``, and the JSON body's other fields as form fields (each value JSON, or a bare word)."""


class MapEncoding(MapParts):
    """A map: exactly one of ``grid``, ``rows``, ``occupancy_grid``, or the multipart parts
    ``yaml`` and ``image``."""

    model_config = STRICT

    grid: list[list[int]] | None = Field(
        default=None, description="Rows of cells: 0 free, 1 blocked, -1 unknown; row 0 on top."
    )
    rows: list[str] | None = Field(
        default=None,
        description="Rows of Moving AI characters: `.` `G` `S` free, `@` `T` `O` `W` blocked.",
    )
    occupancy_grid: dict[str, Any] | None = Field(
        default=None,
        description="A `nav_msgs/OccupancyGrid` as rosbridge writes it: `info` (`resolution`, "
        "`width`, `height`, `origin` pose) and `data`, row-major, row 0 at the origin (the "
        "bottom of the image), -1 unknown or 0..100.",
        examples=[EXAMPLE_OCCUPANCY_GRID],
    )
    resolution: float | None = Field(
        default=None,
        description="With `grid`/`rows`: meters per cell, 0.0001 to 1000 (default 1).",
    )
    origin: list[float] | None = Field(
        default=None,
        description="With `grid`/`rows`: `[x, y, yaw]` of the bottom-left cell's lower-left "
        "corner (default `[0, 0, 0]`).",
    )

    @model_validator(mode="after")
    def _one_encoding(self) -> MapEncoding:
        kinds = ("grid", "rows", "occupancy_grid", "yaml")
        given = [k for k in kinds if getattr(self, k) is not None]
        if self.image is not None and self.yaml is None:
            raise ValueError("the 'image' part needs its 'yaml' part")
        if len(given) != 1:
            got = " and ".join(given) if given else "neither"
            raise ValueError(
                "give exactly one map: 'grid', 'rows', 'occupancy_grid', or the multipart "
                f"parts 'yaml' and 'image'; got {got}"
            )
        if self.yaml is not None and self.image is None:
            raise ValueError("the 'yaml' part needs its 'image' part (the YAML's image name is "
                             "not looked up)")  # fmt: skip
        framed = [k for k in ("resolution", "origin") if getattr(self, k) is not None]
        if framed and given[0] not in ("grid", "rows"):
            raise ValueError(
                f"{' and '.join(framed)} go with 'grid' or 'rows'; a {given[0]} map has its own"
            )
        return self


# pydantic lists the bases' fields from the right: the map, the plan's options, then the ends.
class MapCreate(PlanOptions, MapEncoding):
    """A map (exactly one of ``grid``, ``rows``, ``occupancy_grid``, or the multipart parts
    ``yaml`` and ``image``), with an optional ``start`` and ``goal`` that also create a plan."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                EXAMPLE_MAP,
                {"grid": [[1 if ch == "@" else 0 for ch in row] for row in EXAMPLE_MAP["rows"]]},
                {"grid": [[0, 0, -1], [0, 1, 0]], "resolution": 0.05, "origin": [-1.0, 2.0, 0.0]},
                {
                    "occupancy_grid": EXAMPLE_OCCUPANCY_GRID,
                    "start": {"x": -0.75, "y": 0.75},
                    "goal": {"x": 0.25, "y": 0.25},
                    "robot_radius": 0.2,
                },
            ]
        },
    )

    start: CellOrPoint | None = None
    goal: CellOrPoint | None = None
    waypoints: Waypoints = Field(default_factory=list)
    fleet: FleetName = None
    name: PlanName = None

    @model_validator(mode="after")
    def _both_ends(self) -> MapCreate:
        if (self.start is None) != (self.goal is None):
            missing = "goal" if self.goal is None else "start"
            raise ValueError(f"'start' and 'goal' go together; {missing!r} is missing")
        if self.waypoints and self.start is None:
            raise ValueError("'waypoints' need a 'start' and a 'goal'")
        if self.name is not None and self.start is None:
            raise ValueError("'name' needs a 'start' and a 'goal'")
        if self.fleet is not None and self.start is None:
            raise ValueError("'fleet' needs a 'start' and a 'goal'")
        return self


class MapPublic(BaseModel):
    """A map's identity and size; ``plan`` when the upload asked for one."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "map_id": EXAMPLE_MAP_ID,
                    "height": 5,
                    "width": 6,
                    "free_cells": 28,
                    "occupied_cells": 2,
                    "unknown_cells": 0,
                    "resolution": 1.0,
                    "origin": [0.0, 0.0, 0.0],
                    "plan": {**EXAMPLE_PLAN, "preview": {**EXAMPLE_PLAN["preview"]}},
                }
            ]
        }
    )

    map_id: str = Field(
        description="Hex SHA-256 of the map's shape, occupancy, resolution and origin."
    )
    height: int = Field(ge=1)
    width: int = Field(ge=1)
    free_cells: int = Field(ge=0, description="Known cells below the occupied threshold (65).")
    occupied_cells: int = Field(ge=0, description="Cells of occupancy 65 or more.")
    unknown_cells: int = Field(ge=0, description="Cells of occupancy -1.")
    resolution: float = Field(gt=0, description="Meters per cell.")
    origin: list[float] = Field(
        min_length=3, max_length=3, description="`[x, y, yaw]` of the map's lower-left corner."
    )
    plan: PlanPublic | None = Field(default=None, description="When `start` and `goal` were given.")
    zones: ZonesPublic | None = Field(
        default=None, description="A zoned map's zones (`POST /maps/{map_id}/zones`), else null."
    )

"""Maps: ``POST /maps`` (with an optional first plan) and ``GET /maps/{map_id}``."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

from schemas.plans import (
    EXAMPLE_MAP,
    EXAMPLE_MAP_ID,
    EXAMPLE_PLAN,
    PARAMS_DESCRIPTION,
    STRICT,
    Cell,
    PlanPublic,
    Preset,
)

__all__ = ["MapCreate", "MapPublic"]


class MapCreate(BaseModel):
    """A map as a ``grid`` of 0/1 or as Moving AI ``rows`` (exactly one), with an optional
    ``start`` and ``goal`` that also create a plan."""

    model_config = ConfigDict(
        **STRICT,
        json_schema_extra={
            "examples": [
                EXAMPLE_MAP,
                {"grid": [[1 if ch == "@" else 0 for ch in row] for row in EXAMPLE_MAP["rows"]]},
            ]
        },
    )

    grid: list[list[int]] | None = Field(
        default=None, description="Rows of cells: 0 free, 1 blocked."
    )
    rows: list[str] | None = Field(
        default=None,
        description="Rows of Moving AI characters: `.` `G` `S` free, `@` `T` `O` `W` blocked.",
    )
    start: Cell | None = None
    goal: Cell | None = None
    preset: Preset = "wide"
    params: dict[str, Any] = Field(default_factory=dict, description=PARAMS_DESCRIPTION)
    allow_narrow: bool | None = None

    @model_validator(mode="after")
    def _one_encoding_and_both_ends(self) -> MapCreate:
        if (self.grid is None) == (self.rows is None):
            given = "both" if self.grid is not None else "neither"
            raise ValueError(f"give exactly one of 'grid' or 'rows'; got {given}")
        if (self.start is None) != (self.goal is None):
            missing = "goal" if self.goal is None else "start"
            raise ValueError(f"'start' and 'goal' go together; {missing!r} is missing")
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
                    "plan": {**EXAMPLE_PLAN, "preview": {**EXAMPLE_PLAN["preview"]}},
                }
            ]
        }
    )

    map_id: str = Field(description="Hex SHA-256 of the map's shape and cells.")
    height: int = Field(ge=1)
    width: int = Field(ge=1)
    free_cells: int = Field(ge=0)
    plan: PlanPublic | None = Field(default=None, description="When `start` and `goal` were given.")

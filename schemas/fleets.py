"""Fleets: ``GET /fleets/{fleet}``."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from schemas.passages import PassagePublic
from schemas.plans import XY, Cell, Pose, Status

__all__ = ["FleetPublic", "FleetRobotPublic", "HeldPassagePublic"]


class FleetRobotPublic(BaseModel):
    """A robot of a fleet: where it was last told to be, and what it waits for."""

    plan_id: str
    position: Cell = Field(description="The cell it was last told to move to (or its start).")
    position_xy: XY = Field(description="That cell's center in meters.")
    status: Status
    waiting_for: str | None = Field(
        default=None,
        description="Waiting: the `plan_id` of the robot it waits for (standing on its goal, or "
        "holding a passage it needs).",
    )
    previous: Cell = Field(description="The cell it stood on when last told (until its next step).")
    goal: Cell
    radius: float = Field(ge=0, description="The robot's radius, meters.")
    holds: list[int] = Field(
        default_factory=list, description="The ids of the passages it holds (`passages`)."
    )
    poses: list[Pose] | None = Field(
        default=None,
        description="With `?ahead=true`: its last step's path ahead (`poses`), else null.",
    )


class HeldPassagePublic(PassagePublic):
    """A narrow passage of the fleet's map (for the fleet's radius), and who holds it."""

    held_by: list[str] = Field(
        default_factory=list,
        description="The `plan_id`s of the robots holding it (of its group: passages whose "
        "waiting zones meet are held as one).",
    )


class FleetPublic(BaseModel):
    """The robots of a fleet, on its map."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "fleet": "warehouse-a",
                    "map_id": "2f68cb9d10f4ad46475d5a3851711826daff07c5d2a4479cee604bc39e2872ca",
                    "robot_radius": 0.0,
                    "robots": [
                        {
                            "plan_id": "9f1c2a7be04d4f65a3c8e2b17d90c5aa",
                            "position": [1, 1],
                            "position_xy": [1.5, 3.5],
                            "status": "waiting",
                            "waiting_for": "0b7d1e4a9c2f4e3b8a6d5c4b3a291807",
                            "previous": [1, 1],
                            "goal": [4, 5],
                            "radius": 0.0,
                            "holds": [],
                        }
                    ],
                    "passages": [],
                }
            ]
        }
    )

    fleet: str
    map_id: str
    robot_radius: float = Field(
        ge=0, description="The radius its passages are found for (its first robot's), meters."
    )
    robots: list[FleetRobotPublic]
    passages: list[HeldPassagePublic] = Field(default_factory=list)

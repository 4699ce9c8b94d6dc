"""Fleets: ``GET /fleets/{fleet}``."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from schemas.plans import Status
from schemas.points import XY, Cell, Pose

__all__ = ["FleetPublic", "FleetRobotPublic", "FleetSolvePublic"]


class FleetRobotPublic(BaseModel):
    """A robot of a fleet: where it was last told to be, its route left, and what it waits for."""

    plan_id: str
    name: str | None = Field(default=None, description="Its plan's `name`, when it has one.")
    position: Cell = Field(description="The cell it was last told to move to (or its start).")
    position_xy: XY = Field(description="That cell's center in meters.")
    status: Status
    waiting_for: str | None = Field(
        default=None,
        description="Waiting: the `plan_id` of the robot whose move it waits for (null when no "
        "robot holds it up: the client's obstacles, or a fleet whose last solve failed).",
    )
    previous: Cell = Field(description="The cell it stood on when last told (until its next step).")
    goal: Cell = Field(description="Its plan's goal.")
    goal_node: Cell = Field(description="The roadmap node its goal joins: where it stops.")
    radius: float = Field(ge=0, description="The robot's radius, meters.")
    remaining: list[Cell] = Field(
        default_factory=list, description="The roadmap nodes it still has to visit, in order."
    )
    remaining_xy: list[XY] = Field(default_factory=list, description="The same in meters.")
    moves_done: int = Field(ge=0, description="Moves of the joint plan it has done.")
    moves_total: int = Field(ge=0, description="Moves of the joint plan it has in all.")
    parked: bool = Field(
        default=False,
        description="Silent longer than `PLANNER_FLEET_LEASE_SECONDS`: the others are planned "
        "around it where it last was, until it steps again.",
    )
    poses: list[Pose] | None = Field(
        default=None,
        description="With `?ahead=true`: its last step's path ahead (`poses`), else null.",
    )


class FleetSolvePublic(BaseModel):
    """The fleet's last solve of its joint plan."""

    status: Literal["pending", "solved", "timeout", "unsolvable", "unreachable"] = Field(
        description="`solved`; `timeout` or `unsolvable` (the previous plan is kept, robots "
        "outside it wait); `unreachable` (a robot has no roadmap node in reach); `pending` "
        "(not solved yet: at the next step)."
    )
    agents: int = Field(default=0, ge=0, description="Robots planned together.")
    solve_ms: float = Field(default=0.0, ge=0)
    sum_of_costs: int = Field(default=0, ge=0, description="Moves and waits until each rests.")
    lower_bound: int = Field(
        default=0,
        ge=-1,
        description="The sum of each robot's own shortest (-1: a goal out of reach).",
    )
    makespan: int = Field(default=0, ge=0)
    at: float | None = Field(default=None, description="When (seconds since the epoch).")


class FleetPublic(BaseModel):
    """The robots of a fleet, on its map, and its joint plan's last solve."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "fleet": "warehouse-a",
                    "map_id": "2f68cb9d10f4ad46475d5a3851711826daff07c5d2a4479cee604bc39e2872ca",
                    "robot_radius": 0.0,
                    "roadmap": {"nodes": 28, "edges": 45},
                    "robots": [
                        {
                            "plan_id": "9f1c2a7be04d4f65a3c8e2b17d90c5aa",
                            "position": [1, 1],
                            "position_xy": [1.5, 3.5],
                            "status": "waiting",
                            "waiting_for": "0b7d1e4a9c2f4e3b8a6d5c4b3a291807",
                            "previous": [1, 1],
                            "goal": [4, 5],
                            "goal_node": [4, 5],
                            "radius": 0.0,
                            "remaining": [[1, 2], [2, 2]],
                            "remaining_xy": [[2.5, 3.5], [2.5, 2.5]],
                            "moves_done": 1,
                            "moves_total": 8,
                        }
                    ],
                    "solve": {
                        "status": "solved",
                        "agents": 2,
                        "solve_ms": 1.2,
                        "sum_of_costs": 16,
                        "lower_bound": 15,
                        "makespan": 9,
                        "at": 1765000000.0,
                    },
                }
            ]
        }
    )

    fleet: str
    map_id: str
    robot_radius: float = Field(
        ge=0, description="The radius its roadmap keeps robots apart for (its first robot's)."
    )
    roadmap: dict[str, int] = Field(description="The roadmap's `nodes` and `edges`.")
    robots: list[FleetRobotPublic]
    solve: FleetSolvePublic

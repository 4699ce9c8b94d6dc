"""Offline multi-agent path finding: ``POST /maps/{map_id}/mapf``."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from schemas.plans import Preset
from schemas.points import STRICT, Cell, CellOrPoint

__all__ = ["MapfAgent", "MapfCreate", "MapfPublic", "PlanGoalUpdate"]


class MapfAgent(BaseModel):
    """One agent: where it starts and where it must end."""

    model_config = STRICT

    start: Cell
    goal: Cell


class MapfCreate(BaseModel):
    """Agents to plan together on a map's roadmap (its free cells, 4-connected, with radius 0)."""

    model_config = ConfigDict(
        **STRICT,
        json_schema_extra={
            "examples": [
                {"agents": [{"start": [0, 0], "goal": [4, 5]}, {"start": [4, 5], "goal": [0, 0]}],
                 "time_limit_s": 2.0}
            ]
        },
    )  # fmt: skip

    agents: list[MapfAgent] = Field(min_length=1, max_length=2000)
    robot_radius: float = Field(
        default=0.0, ge=0, le=100, description="The agents' radius in meters: the roadmap's."
    )
    time_limit_s: float = Field(
        default=10.0, gt=0, le=60, description="The solver's budget (within the request's)."
    )
    preset: Preset = Field(default="wide", description="The roadmap's edge costs.")


class MapfPublic(BaseModel):
    """The joint plan: each agent's cell at each time step (all of one length)."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {"solved": True, "status": "solved",
                 "paths": [[[0, 0], [0, 1]], [[0, 1], [1, 1]]], "makespan": 1,
                 "sum_of_costs": 2, "lower_bound": 2, "solve_ms": 0.4}
            ]
        }
    )  # fmt: skip

    solved: bool
    status: str = Field(description="`solved`, `timeout` or `unsolvable`.")
    paths: list[list[Cell]] = Field(
        description="Per agent, its node's cell at each time step (a start or goal off the "
        "roadmap joins its nearest node: the path runs between those nodes)."
    )
    makespan: int = Field(ge=0)
    sum_of_costs: int = Field(ge=0, description="Time steps until each agent rests, summed.")
    lower_bound: int = Field(description="The sum of each agent's own shortest (-1: unreachable).")
    solve_ms: float = Field(ge=0)


class PlanGoalUpdate(BaseModel):
    """A fleet robot's new goal: ``PATCH /plan/{plan_id}``."""

    model_config = ConfigDict(**STRICT, json_schema_extra={"examples": [{"goal": [4, 0]}]})

    goal: CellOrPoint = Field(description="A cell, or a point `{x, y, yaw?}` in meters.")

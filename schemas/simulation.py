"""The paper's experiment: ``POST /maps/{map_id}/simulate``."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from schemas.plans import PlanEnds, PlanOptions, Status, TrajectoryMetrics
from schemas.points import Cell

__all__ = ["ObstacleMotion", "SimulationCreate", "SimulationMetrics", "SimulationPublic"]

ObstacleMotion = Literal["turns", "simultaneous"]

EXAMPLE_METRICS: dict[str, Any] = {
    "reached": True,
    "status": "arrived",
    "iterations": 2,
    "moves": 2,
    "waits": 0,
    "replans": 0,
    "path_length": 2.828427,
    "arc_cost": 1.414214,
    "gates": 0,
    "tunnels": 0,
    "narrow_fallback": False,
    "min_clearance": 1.0,
    "mean_clearance": 1.0,
    "contact_ratio": 1.0,
    "length_m": 2.828427,
    "min_clearance_m": 1.0,
    "mean_clearance_m": 1.0,
    "collisions": 0,
    "analysis_ms": 0.05,
    "step_us": 4.2,
    "episode_ms": 0.9,
}


class SimulationCreate(PlanOptions, PlanEnds):
    """One seeded episode among ``dynamic_count`` randomly moving obstacles."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {"start": [0, 0], "goal": [4, 5], "preset": "wfs-mmas", "dynamic_count": 2,
                 "seed": 7, "max_steps": 100}
            ]
        }
    )  # fmt: skip

    dynamic_count: int = Field(default=10, ge=0, description="How many obstacles move about.")
    seed: int = Field(default=0, ge=0, le=2**63 - 1)
    obstacle_motion: ObstacleMotion = Field(
        default="turns",
        description="`turns`: the obstacles move, then the robot sees them and moves (the "
        "paper's simulation); `simultaneous`: the robot decides from where the obstacles are at "
        "the tick's start while they all move at once, as in the real world. A collision is the "
        "robot ending a tick on an obstacle's cell or swapping cells with one, in both.",
    )
    max_steps: int | None = Field(
        default=None,
        ge=1,
        le=1_000_000,
        description="Default: 4 (H + W) + 4 len(path). The server refuses more than its "
        "`PLANNER_MAX_SIMULATION_STEPS` (default 200000) with a 422; the bound 1000000 here "
        "caps that setting.",
    )


class SimulationMetrics(TrajectoryMetrics):
    """The paper's per-episode figures and a robotics user's: the trajectory's, and the
    episode's own."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_METRICS]})

    reached: bool
    status: Status
    gates: int = Field(ge=0)
    tunnels: int = Field(ge=0)
    narrow_fallback: bool
    collisions: int = Field(
        ge=0,
        description="Ticks ending on an obstacle's cell or swapping cells with one: 0 for "
        "`wide` and `shortest` (their dynamic margin); the paper's presets can collide when "
        "`obstacle_motion` is `simultaneous`.",
    )
    analysis_ms: float = Field(ge=0)
    step_us: float = Field(ge=0, description="Mean compute time of one step.")
    episode_ms: float = Field(ge=0, description="Compute time of the whole episode.")


class SimulationPublic(BaseModel):
    """The robot's cells, start first, and the episode's metrics."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [{"trajectory": [[0, 0], [1, 1], [2, 2]], "metrics": EXAMPLE_METRICS}]
        }
    )

    trajectory: list[Cell]
    metrics: SimulationMetrics
    obstacle_motion: ObstacleMotion = Field(default="turns", description="How the obstacles moved.")

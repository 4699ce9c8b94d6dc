"""Stepping: ``POST /plan/{plan_id}/step``."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidatorFunctionWrapHandler, WrapValidator

from schemas.plans import Status
from schemas.points import COORDINATE_MAX, STRICT, XY, Cell, CellOrPoint, Obstacle, Pose, XYPublic
from schemas.scans import LaserScan, ScanPose

__all__ = ["Move", "StepCreate", "StepPublic"]

Move = Literal["N", "NE", "E", "SE", "S", "SW", "W", "NW", "WAIT"]


def _cells_at_once(value: Any, validate: ValidatorFunctionWrapHandler) -> Any:
    """A list of nothing but valid ``[row, col]`` cells (a step's usual obstacles) as it is,
    checked here in one pass; anything else validated item by item, with the same errors."""
    if type(value) is list:
        for cell in value:
            if type(cell) is not list or len(cell) != 2:
                break
            r, c = cell
            if type(r) is not int or type(c) is not int:  # not bool: strict refuses them
                break
            if not (0 <= r <= COORDINATE_MAX and 0 <= c <= COORDINATE_MAX):
                break
        else:
            return value
    return validate(value)


Obstacles = Annotated[list[Obstacle], WrapValidator(_cells_at_once)]


class StepCreate(BaseModel):
    """Where the dynamic obstacles are now (and, optionally, where the robot really is)."""

    model_config = ConfigDict(
        **STRICT,
        json_schema_extra={
            "examples": [
                {"seq": 0, "dynamic_obstacles": [[1, 2]], "position": [0, 0]},
                {"seq": 1, "dynamic_obstacles": [[1, 2], {"x": 3.1, "y": 2.4, "radius": 0.3}]},
            ]
        },
    )

    seq: int | None = Field(
        default=None,
        ge=0,
        le=2**62,
        description="The last step's `seq` + 1 for a new step; the last `seq` again for a retry.",
    )
    dynamic_obstacles: Obstacles = Field(
        default_factory=list,
        description="Dynamic obstacles this step: cells `[r, c]`, and circles `{x, y, radius}` "
        "in meters, each blocking every cell whose center is within `radius + robot_radius`.",
    )
    position: CellOrPoint | None = Field(
        default=None,
        description="Where the robot really is: a cell, or a point in meters with its heading "
        "`yaw` if known (the answer's `poses` start there).",
    )
    scan: LaserScan | None = Field(
        default=None,
        description="What the robot's laser sees now: its returns mark the map's live layer, "
        "its rays clear it (docs/live.md); every plan on the map then steps around the marks.",
    )
    scan_pose: ScanPose | None = Field(
        default=None,
        description="The sensor's pose in the map frame; by default the step's `position` "
        "(a point with its `yaw`).",
    )


class StepPublic(BaseModel):
    """The move to make now."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "seq": 0,
                    "previous": [0, 0],
                    "position": [1, 0],
                    "position_xy": [0.5, 3.5],
                    "move": "S",
                    "status": "replanned",
                    "iteration": 1,
                    "path_length": 1.0,
                    "arc_cost": 6.828427,
                    "remaining": 6.828427,
                    "narrow_fallback": False,
                    "poses": [
                        {"x": 0.5, "y": 4.5, "yaw": -1.5707963267948966},
                        {"x": 0.5, "y": 3.828125, "yaw": -1.5707963267948966},
                        {"x": 0.5, "y": 3.15625, "yaw": -1.5707963267948966},
                        {
                            "x": 0.5415256454488546,
                            "y": 2.7876997031348543,
                            "yaw": -1.346396851538483,
                        },
                        {
                            "x": 0.6640203125366184,
                            "y": 2.4376300570865443,
                            "yaw": -1.1219973762820692,
                        },
                        {
                            "x": 0.8613416071623254,
                            "y": 2.123595015671473,
                            "yaw": -0.8975979010256554,
                        },
                        {
                            "x": 1.1235950156714725,
                            "y": 1.8613416071623257,
                            "yaw": -0.6731984257692416,
                        },
                        {
                            "x": 1.4376300570865443,
                            "y": 1.6640203125366182,
                            "yaw": -0.44879895051282787,
                        },
                        {
                            "x": 1.7876997031348543,
                            "y": 1.5415256454488544,
                            "yaw": -0.22439947525641404,
                        },
                        {"x": 2.15625, "y": 1.5, "yaw": 0.0},
                        {"x": 2.5, "y": 1.5, "yaw": 0.0},
                    ],
                    "remaining_m": 7.697889852018546,
                }
            ]
        }
    )

    seq: int = Field(ge=0)
    previous: Cell
    position: Cell = Field(description="The cell to move to now.")
    position_xy: XY = Field(description="That cell's center in meters.")
    move: Move
    status: Status
    iteration: int = Field(ge=0)
    path_length: float = Field(ge=0)
    arc_cost: float = Field(ge=0)
    remaining: float | None = Field(description="Cost-to-go `k`; null when out of reach.")
    narrow_fallback: bool = Field(
        default=False,
        description="This move follows a way through tight tunnels that sealing would shut: the "
        "plan's own narrow fallback, or a detour taken because the wide way is blocked (parked "
        "for `patience` steps) or because the robot was reported in a sealed pocket.",
    )
    poses: list[Pose] = Field(
        default_factory=list,
        description="The path ahead, poses at most one resolution apart: from the reported point "
        "(else from `position`'s center), at least the plan's `horizon_m` meters or to the goal, "
        "clear of this step's dynamic obstacles; shorter where they block the way, one pose when "
        "the robot waits.",
    )
    remaining_m: float | None = Field(
        default=None,
        description="Meters to the goal: along `poses`, then the grid's cost-to-go `k` in meters "
        "from where they end; null when out of reach.",
    )
    blocked_at: XYPublic | None = Field(
        default=None,
        description="Where the way ahead is cut when no way round exists (the center of the "
        "route's first blocked cell, meters); null when the poses go on, round any obstacle.",
    )
    waiting_for: str | None = Field(
        default=None,
        description="A fleet robot waiting: the `plan_id` of the robot whose move of the joint "
        "plan it waits for (null when no robot holds it up: the client's obstacles, or a fleet "
        "whose solve failed); else null.",
    )

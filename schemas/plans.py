"""Plans: ``POST /plan``, ``GET /plan/{plan_id}``."""

from __future__ import annotations

from typing import Annotated, Any, Literal, get_args

from pydantic import BaseModel, ConfigDict, Field

from schemas.examples import EXAMPLE_MAP_ID, EXAMPLE_PLAN, EXAMPLE_TRAJECTORY_METRICS
from schemas.passages import NarrowestPublic
from schemas.points import STRICT, XY, Cell, CellOrPoint, Pose, XYPublic

__all__ = [
    "GOAL_TOLERANCE_MAX",
    "MAX_FOOTPRINT_VERTICES",
    "MAX_WAYPOINTS",
    "PRESET_NAMES",
    "AnalysisPublic",
    "DetourPublic",
    "Footprint",
    "Motion",
    "PlanCreate",
    "PlanDetail",
    "PlanEnds",
    "PlanName",
    "PlanOptions",
    "PlanPublic",
    "Preset",
    "PreviewPublic",
    "RobotRadius",
    "Status",
    "TrajectoryMetrics",
    "Unknown",
    "UnknownPolicy",
    "Waypoints",
]

Unknown = Literal["blocked", "free"]

GOAL_TOLERANCE_MAX = 100.0
"""Meters of ``goal_tolerance`` at most."""

MAX_WAYPOINTS = 64
"""Waypoints a plan takes at most (the planner's ``MAX_WAYPOINTS``: a test compares)."""

Waypoints = Annotated[
    list[CellOrPoint],
    Field(
        max_length=MAX_WAYPOINTS,
        description="Cells or points (a point with an optional `yaw`) the path passes through, in "
        "order, at most 64: each leg (start, each waypoint, the goal) is planned with the same "
        "preset and parameters; the poses include each waypoint's point "
        "(`preview.waypoint_indices`), and stepping follows the whole route.",
        examples=[[[2, 1], {"x": 4.5, "y": 3.5, "yaw": 0.0}]],
    ),
]
"""A plan's waypoints."""

RobotRadius = Annotated[
    float | None,
    Field(
        default=None,
        ge=0,
        le=100,
        allow_inf_nan=False,
        description="The robot's radius in meters (the planner parameter `robot_radius`, default "
        "0): a cell is traversable when free and its center is more than this from the nearest "
        "blocked cell's center.",
    ),
]
UnknownPolicy = Annotated[
    Unknown | None,
    Field(
        default=None,
        description="How unknown cells and the area outside the map count (the planner "
        "parameter `unknown`): `blocked` (default) or `free`.",
    ),
]

MAX_FOOTPRINT_VERTICES = 32
"""A footprint's vertices at most (the planner's ``MAX_VERTICES``: a test compares)."""

Footprint = Annotated[
    list[Annotated[list[Annotated[float, Field(allow_inf_nan=False)]], Field(min_length=2,
                                                                             max_length=2)]]
    | None,
    Field(
        default=None,
        min_length=3,
        max_length=MAX_FOOTPRINT_VERTICES,
        description="The robot's outline in its own frame, meters, x forward: 3 to 32 `[x, y]` "
        "vertices of a simple polygon holding `[0, 0]` (the pose's point), in place of "
        "`robot_radius` (which becomes the footprint's inscribed radius). Every pose, and the "
        "motion between poses, is free for the footprint at the pose's yaw; the wall term "
        "weighs the footprint's clearance.",
        examples=[[[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]]],
    ),
]  # fmt: skip
"""A robot's footprint polygon."""

Motion = Literal["diff", "car", "car_reverse"]

Preset = Literal["wide", "wfs-mmas", "mmas", "shortest"]
PRESET_NAMES: tuple[str, ...] = get_args(Preset)
"""The planner's presets, in its order (schemas never import the planner: a test compares)."""

Status = Literal["ready", "moving", "waiting", "replanned", "arrived", "blocked", "yielding"]

PARAMS_DESCRIPTION = (
    "Overrides of single planner parameters, each checked by the planner (an unknown name or a "
    "value of the wrong type is a 422): `alpha`, `beta`, `clean_weight`, `clean_radius`, "
    "`seal_tunnels`, `diagonal_cost`, `patience`, `decision`, `allow_narrow`, `robot_radius` "
    "(meters), `unknown` (`blocked` | `free`), `occupied_threshold` (percent), `wall_cost`, "
    "`wide_weight`, `wide_distance` (meters), `dynamic_margin` (cells), `nominal_speed` (m/s: "
    "the preview's `duration_s`), `deviation_m` (meters off its moves: a fleet's re-solve), "
    "`max_detour` (a finite number from 1 to 100, default 1.3: the `wide` route is at most that "
    "many times as long as the shortest route; the preview's `detour`), "
    "`max_velocity` (m/s), `max_acceleration` (m/s²) and `max_angular_velocity` (rad/s): with "
    "`max_velocity`, `duration_s` follows a trapezoid speed profile that slows for curvature, "
    "stops at cusps and counts turns in place."
)


class PlanEnds(BaseModel):
    """Where a plan goes: a request's required ``start`` and ``goal``."""

    model_config = STRICT

    start: CellOrPoint
    goal: CellOrPoint


class PlanOptions(BaseModel):
    """How to plan: the preset, single parameters over it, and the robot; every request that
    plans takes these (a plan, a map uploaded with one, a simulation)."""

    model_config = STRICT

    preset: Preset = "wide"
    params: dict[str, Any] = Field(default_factory=dict, description=PARAMS_DESCRIPTION)
    allow_narrow: bool | None = Field(
        default=None,
        description="Plan through tight tunnels when sealing them cuts the start off the goal "
        "(the planner parameter `allow_narrow`; default true).",
    )
    robot_radius: RobotRadius = None
    footprint: Footprint = None
    motion: Motion | None = Field(
        default=None,
        description="`diff` (default: turns in place), `car` (forward only) or `car_reverse` "
        "(forward and reverse, Reeds-Shepp): a car's path never curves tighter than "
        "`min_turning_radius`, and its poses carry `direction`; it needs a goal `yaw`.",
    )
    min_turning_radius: float | None = Field(
        default=None,
        gt=0,
        le=100,
        allow_inf_nan=False,
        description="A car motion's least turning radius, meters (> 0; required for `car` and "
        "`car_reverse`).",
    )
    unknown: UnknownPolicy = None
    goal_tolerance: float = Field(
        default=0.0,
        ge=0,
        le=GOAL_TOLERANCE_MAX,
        allow_inf_nan=False,
        description="Meters: when the goal cannot be stood on or reached, plan to the reachable "
        "traversable cell nearest to it within this distance (`preview.goal_used`); 0 (default) "
        "keeps the errors (`GOAL_OCCUPIED`, `NO_VALID_PATH`).",
    )


PlanName = Annotated[
    str | None,
    Field(
        default=None,
        min_length=1,
        max_length=64,
        description="A name for the plan (its robot's, say), 1 to 64 characters: the answers "
        "carry it and the live viewer shows it instead of the `plan_id`.",
        examples=["forklift 3"],
    ),
]
"""A plan's optional name."""


# pydantic lists the bases' fields from the right: the ends, then the options, then the own.
class PlanCreate(PlanOptions, PlanEnds):
    """Ask for a plan from ``start`` to ``goal`` on a map already uploaded."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "map_id": EXAMPLE_MAP_ID,
                    "start": [0, 0],
                    "goal": [4, 5],
                    "preset": "wide",
                    "params": {"patience": 3},
                    "allow_narrow": True,
                }
            ]
        },
    )

    map_id: str = Field(min_length=1, max_length=128, description="From `POST /maps`.")
    waypoints: Waypoints = Field(default_factory=list)
    name: PlanName = None


class AnalysisPublic(BaseModel):
    """What the map analysis found, and whether this request computed it."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_PLAN["analysis"]]})

    gates: int = Field(ge=0, description="Zero-width diagonal gaps, never crossed.")
    tunnels: int = Field(ge=0, description="Tight-tunnel cells (one-cell corridors).")
    narrow_fallback: bool = Field(description="The plan goes through tunnels sealing would shut.")
    cache_hit: bool = Field(description="The analysis was not computed for this request.")
    analysis_ms: float = Field(ge=0, description="Time the analysis took when it was computed.")


class DetourPublic(BaseModel):
    """How the ``wide`` route compares with the shortest route (``params.max_detour``)."""

    shortest_m: float = Field(
        ge=0, description="The shortest route's length on the same configuration space, meters "
        "(cell centers to centers; tight tunnels open).",
    )  # fmt: skip
    ratio: float = Field(ge=0, description="The route's `length` over the shortest's.")
    width_kept: float = Field(
        ge=0, le=1, description="The share of the wall term (`clean_weight` / `wide_weight`) the "
        "route was planned with: 1 when no width was given up, 0 for the shortest route on the "
        "sealed grid; `params` holds the weights used.",
    )  # fmt: skip
    tunnels_opened: bool = Field(
        description="Even that was longer than the bound: the route is the shortest one, "
        "through tight tunnels sealing would shut."
    )


class PreviewPublic(BaseModel):
    """The path the robot would follow with no dynamic obstacles."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_PLAN["preview"]]})

    path: list[Cell]
    length: float = Field(ge=0)
    arc_cost: float = Field(ge=0, description="The paper's total arc cost: sum of `k` entered.")
    min_clearance: float = Field(ge=0)
    mean_clearance: float = Field(ge=0)
    contact_ratio: float = Field(ge=0, le=1, description="Share of cells touching an obstacle.")
    path_xy: list[XY] = Field(description="The path's cell centers in the map frame, meters.")
    length_m: float = Field(ge=0, description="The length in meters (cell centers to centers).")
    min_clearance_m: float = Field(
        ge=0, description="Least distance from a path cell to a blocked cell's center, meters."
    )
    mean_clearance_m: float = Field(ge=0, description="`min_clearance_m`'s mean, in meters.")
    poses: list[Pose] = Field(
        default_factory=list,
        description="The path a robot controller follows, meters and radians: from the start "
        "point to the goal point (or `goal_used`), at most one `resolution` apart, every point "
        "of its polyline more than `robot_radius` from blocked cells' centers and at least "
        "`min_clearance_m` less one `resolution`, `yaw` the direction of travel (the last: the "
        "goal's `yaw` when given), turning at most 15 degrees from one pose to the next.",
    )
    length_poses_m: float = Field(default=0.0, ge=0, description="The poses' length, meters.")
    duration_s: float = Field(
        default=0.0,
        ge=0,
        description="Seconds to drive the poses at `params.nominal_speed` (m/s, default 0.5), "
        "each segment at most the `max_speed` of either of its ends' poses.",
    )
    goal_used: XYPublic | None = Field(
        default=None,
        description="The center of the cell planned to instead of the goal, within "
        "`goal_tolerance`, when the goal could not be stood on or reached; else null.",
    )
    goal_offset_m: float = Field(
        default=0.0, ge=0, description="How far `goal_used` is from the goal, meters (else 0)."
    )
    waypoint_indices: list[int] = Field(
        default_factory=list,
        description="The index in `poses` of each waypoint's pose, in order (empty without "
        "waypoints).",
    )
    narrowest: NarrowestPublic | None = Field(
        default=None, description="The narrowest point the path crosses (null on a plain grid)."
    )
    passages: list[int] | None = Field(
        default=None, description="The ids of the passages (`GET /maps/{map_id}/passages`, its "
        "`robot_radius`) the path crosses, in order (null on a plain grid).",
    )  # fmt: skip
    detour: DetourPublic | None = Field(
        default=None, description="How much longer than the shortest route a `wide` route is, "
        "and how much width it gave up to stay within `params.max_detour` (null for the `paper` "
        "decision, a route through waypoints, or a plan that is the shortest by construction).",
    )  # fmt: skip


class PlanPublic(BaseModel):
    """A plan as created."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_PLAN]})

    plan_id: str
    map_id: str
    name: str | None = Field(default=None, description="The plan's name, as it was created.")
    start: Cell
    goal: Cell
    preset: Preset
    params: dict[str, Any] = Field(description="The effective parameter values.")
    status: Status
    position: Cell
    position_xy: XY = Field(description="The robot's cell's center in meters.")
    narrow_fallback: bool = Field(
        default=False,
        description="The robot is now on a way through tight tunnels that sealing would shut "
        "(the plan's own fallback, or a detour while stepping); `analysis.narrow_fallback` says "
        "whether the plan itself needed one.",
    )
    analysis: AnalysisPublic
    preview: PreviewPublic
    waypoints: list[Cell] = Field(
        default_factory=list, description="The cells of the route's waypoints, in order."
    )


class TrajectoryMetrics(BaseModel):
    """How the robot has fared so far."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_TRAJECTORY_METRICS]})

    iterations: int = Field(ge=0)
    moves: int = Field(ge=0)
    waits: int = Field(ge=0)
    replans: int = Field(ge=0)
    path_length: float = Field(ge=0)
    arc_cost: float = Field(ge=0)
    min_clearance: float = Field(ge=0)
    mean_clearance: float = Field(ge=0)
    contact_ratio: float = Field(ge=0, le=1)
    length_m: float = Field(ge=0, description="The trajectory's length in meters.")
    min_clearance_m: float = Field(ge=0)
    mean_clearance_m: float = Field(ge=0)

    def __getitem__(self, name: str) -> Any:
        """``metrics["moves"]`` reads as ``metrics.moves``: the figures by name, as in the JSON."""
        if name not in type(self).model_fields:
            raise KeyError(name)
        return getattr(self, name)


class PlanDetail(PlanPublic):
    """A plan as it stands: the created plan plus the robot's progress."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    **EXAMPLE_PLAN,
                    "status": "moving",
                    "position": [1, 0],
                    "iteration": 1,
                    "leg": 0,
                    "position_xy": [0.5, 3.5],
                    "trajectory": [[0, 0], [1, 0]],
                    "trajectory_xy": [[0.5, 4.5], [0.5, 3.5]],
                    "metrics": EXAMPLE_TRAJECTORY_METRICS,
                }
            ]
        }
    )

    iteration: int = Field(ge=0)
    leg: int = Field(
        default=0,
        ge=0,
        description="Through waypoints: the leg the robot is on (it goes to `waypoints[leg]`, "
        "the goal after the last).",
    )
    trajectory: list[Cell]
    trajectory_xy: list[XY] = Field(description="The trajectory's cell centers, meters.")
    metrics: TrajectoryMetrics

"""A plan as plain JSON-ready data (:meth:`planner.Plan.summary`)."""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from planner.analysis.analyse import Analysis
from planner.motion.robots import robot_of
from planner.params import Params
from planner.plans.bounded import Detour
from planner.plans.whole_wave import Wave

__all__ = ["Summarised", "plan_summary"]


class Summarised(Protocol):
    """What a summary reads of a :class:`~planner.Plan` (this module does not import it:
    ``planning`` imports this one)."""

    # fmt: off
    @property
    def start(self) -> tuple[int, int]: ...
    @property
    def goal(self) -> tuple[int, int]: ...
    @property
    def preset(self) -> str: ...
    @property
    def params(self) -> Params: ...
    @property
    def analysis(self) -> Analysis: ...
    @property
    def wave(self) -> Wave: ...
    @property
    def path(self) -> npt.NDArray[np.int64]: ...
    @property
    def path_xy(self) -> npt.NDArray[np.float64]: ...
    @property
    def poses(self) -> npt.NDArray[np.float64]: ...
    @property
    def directions(self) -> npt.NDArray[np.int8]: ...
    @property
    def max_speeds(self) -> npt.NDArray[np.float64]: ...
    @property
    def length(self) -> float: ...
    @property
    def arc_cost(self) -> float: ...
    @property
    def gates(self) -> int: ...
    @property
    def tunnels(self) -> int: ...
    @property
    def narrow_fallback(self) -> bool: ...
    @property
    def min_clearance(self) -> float: ...
    @property
    def mean_clearance(self) -> float: ...
    @property
    def contact_ratio(self) -> float: ...
    @property
    def length_m(self) -> float: ...
    @property
    def min_clearance_m(self) -> float: ...
    @property
    def mean_clearance_m(self) -> float: ...
    @property
    def length_poses_m(self) -> float: ...
    @property
    def duration_s(self) -> float: ...
    @property
    def goal_used(self) -> tuple[float, float] | None: ...
    @property
    def goal_offset_m(self) -> float: ...
    @property
    def waypoints(self) -> list[tuple[int, int]]: ...
    @property
    def waypoint_indices(self) -> list[int]: ...
    @property
    def detour(self) -> Detour | None: ...
    @property
    def elapsed_ms(self) -> float: ...
    # fmt: on


def plan_summary(plan: Summarised) -> dict[str, Any]:
    """The plan as plain JSON-ready data: its ends, parameters, path and figures, its poses
    (with their directions for a footprint or a car) and timings."""
    shaped = robot_of(plan.params, plan.analysis.frame.resolution) is not None
    return {
        "start": list(plan.start),
        "goal": list(plan.goal),
        "preset": plan.preset,
        "params": plan.params.as_dict(),
        "path": plan.path.tolist(),
        "length": round(plan.length, 6),
        "arc_cost": round(plan.arc_cost, 6),
        "gates": plan.gates,
        "tunnels": plan.tunnels,
        "sealed": plan.analysis.sealed,
        "narrow_fallback": plan.narrow_fallback,
        "min_clearance": round(plan.min_clearance, 4),
        "mean_clearance": round(plan.mean_clearance, 4),
        "contact_ratio": round(plan.contact_ratio, 4),
        "path_xy": plan.path_xy.round(6).tolist(),
        "length_m": round(plan.length_m, 6),
        "min_clearance_m": round(plan.min_clearance_m, 6),
        "mean_clearance_m": round(plan.mean_clearance_m, 6),
        "poses": plan.poses.tolist(),
        "directions": plan.directions.tolist() if shaped else None,
        "length_poses_m": round(plan.length_poses_m, 6),
        "max_speeds": [None if math.isinf(v) else v for v in plan.max_speeds.tolist()],
        "duration_s": round(plan.duration_s, 6),
        "goal_used": None if plan.goal_used is None else list(plan.goal_used),
        "goal_offset_m": round(plan.goal_offset_m, 6),
        "waypoints": [list(cell) for cell in plan.waypoints],
        "waypoint_indices": plan.waypoint_indices,
        "detour": _detour(plan),
        "analysis_ms": round(plan.analysis.elapsed_ms, 3),
        "wave_ms": round(plan.wave.elapsed_ms, 3),
        "elapsed_ms": round(plan.elapsed_ms, 3),
    }


def _detour(plan: Summarised) -> dict[str, Any] | None:
    d, res = plan.detour, plan.analysis.frame.resolution
    if d is None:
        return None
    ratio = plan.length / d.shortest if d.shortest > 0 else 1.0
    return {"shortest_m": round(d.shortest * res, 6), "ratio": round(ratio, 6),
            "width_kept": d.width_kept, "tunnels_opened": d.tunnels_opened}  # fmt: skip

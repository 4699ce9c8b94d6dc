"""A plan as plain JSON-ready data (:meth:`planner.Plan.summary`)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from planner.motion.robots import robot_of

if TYPE_CHECKING:
    from planner.plans.planning import Plan

__all__ = ["plan_summary"]


def plan_summary(plan: Plan) -> dict[str, Any]:
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


def _detour(plan: Plan) -> dict[str, Any] | None:
    d, res = plan.detour, plan.analysis.frame.resolution
    if d is None:
        return None
    ratio = plan.length / d.shortest if d.shortest > 0 else 1.0
    return {"shortest_m": round(d.shortest * res, 6), "ratio": round(ratio, 6),
            "width_kept": d.width_kept, "tunnels_opened": d.tunnels_opened}  # fmt: skip

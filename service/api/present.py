"""Presentation: what the resources return (planner objects) as the response models."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import planner
from planner import clearance_metrics
from schemas import (
    FleetPublic,
    MapPublic,
    PassagePublic,
    PassagesPublic,
    PlanDetail,
    PlanPublic,
    SimulationPublic,
    StepPublic,
    ZonesPublic,
)
from service.resources.fleet_solve import node_cell
from service.resources.fleets import FleetView
from service.resources.maps import MapView
from service.resources.passages import PassageSet
from service.resources.plans import PlanView, StepView

__all__ = [
    "center",
    "fleet_public",
    "map_public",
    "meters",
    "nav_path",
    "passages_public",
    "plan_detail",
    "plan_public",
    "simulation_public",
    "step_answer",
    "step_public",
]

PREVIEW_KEYS = (
    "path",
    "length",
    "arc_cost",
    "min_clearance",
    "mean_clearance",
    "contact_ratio",
    "path_xy",
    "length_m",
    "min_clearance_m",
    "mean_clearance_m",
    "length_poses_m",
    "goal_offset_m",
)


def map_public(view: MapView) -> MapPublic:
    m = view.robot_map
    h, w = m.shape
    plan = None if view.plan is None else plan_public(view.plan)
    return MapPublic(
        map_id=view.map_id,
        height=h,
        width=w,
        free_cells=m.free_cells(),
        occupied_cells=m.occupied_cells(),
        unknown_cells=m.unknown_cells,
        resolution=m.resolution,
        origin=list(m.origin),
        plan=plan,
        zones=None if m.zones is None else ZonesPublic.model_validate(m.zones.as_dict()),
    )


def meters(trajectory: Any, analysis: planner.Analysis) -> dict[str, float]:
    """A trajectory's ``length_m``, ``min_clearance_m`` and ``mean_clearance_m``: distances
    between cell centers and to the nearest blocked cell's center, in meters."""
    cells = np.asarray(trajectory, dtype=np.int64).reshape(-1, 2)
    res = analysis.frame.resolution
    steps = np.abs(np.diff(cells, axis=0)).sum(axis=1)
    length = float(np.count_nonzero(steps == 1) + np.count_nonzero(steps == 2) * np.sqrt(2.0))
    min_c, mean_c, _ = clearance_metrics(cells, analysis)
    return {
        "length_m": round(length * res, 6),
        "min_clearance_m": round(min_c * res, 6),
        "mean_clearance_m": round(mean_c * res, 6),
    }


def plan_public(view: PlanView) -> PlanPublic:
    return PlanPublic.model_validate(_plan_fields(view))


def plan_detail(view: PlanView) -> PlanDetail:
    state = view.state
    trajectory = np.asarray(state.trajectory, dtype=np.int64).reshape(-1, 2)
    min_c, mean_c, contact = clearance_metrics(trajectory, view.plan.analysis)
    metrics = {
        "iterations": state.iteration,
        "moves": len(trajectory) - 1,
        "waits": state.waits,
        "replans": state.replans,
        "path_length": round(state.path_length, 6),
        "arc_cost": round(state.arc_cost, 6),
        "min_clearance": round(min_c, 4),
        "mean_clearance": round(mean_c, 4),
        "contact_ratio": round(contact, 4),
        **meters(trajectory, view.plan.analysis),
    }
    frame = view.plan.analysis.frame
    return PlanDetail.model_validate(
        {
            **_plan_fields(view),
            "iteration": state.iteration,
            "leg": state.leg,
            "trajectory": trajectory.tolist(),
            "trajectory_xy": frame.centers(trajectory).round(6).tolist(),
            "metrics": metrics,
        }
    )


def step_public(view: StepView) -> StepPublic:
    return StepPublic.model_validate(step_answer(view))


def step_answer(view: StepView) -> dict[str, Any]:
    """The step's answer as :class:`StepPublic` writes it, built directly: a step is the hot
    path, and validating values the planner made costs more than the step's own bookkeeping."""
    step = view.step
    r, c = step.position
    return {
        "seq": int(step.seq),
        "previous": [int(step.previous[0]), int(step.previous[1])],
        "position": [int(r), int(c)],
        "position_xy": center(view.frame, r, c),
        "move": step.move,
        "status": step.status,
        "iteration": int(step.iteration),
        "path_length": float(step.path_length),
        "arc_cost": float(step.arc_cost),
        "remaining": None if step.remaining is None else float(step.remaining),
        "narrow_fallback": bool(step.narrow_fallback),
        "poses": _step_poses(step.poses, view.zones),
        "remaining_m": step.remaining_m,
        "blocked_at": _point(step.blocked_at),
        "waiting_for": view.waiting_for,
    }


def fleet_public(view: FleetView) -> FleetPublic:
    """The fleet's robots by priority (the order they joined), and its last solve."""
    state, graph = view.state, view.fleet_map.graph
    extras = state.get("extras", [])
    robots = sorted(state["robots"].items(), key=lambda item: item[1]["rank"])
    out = []
    for plan_id, robot in robots:
        remaining = [node_cell(m[1], robot, extras, graph) for m in robot["moves"][robot["done"] :]]
        goal_node = [int(v) for v in graph.cells[robot["goal_node"]]]
        entry = {
            "plan_id": plan_id,
            "name": robot.get("name"),
            "position": robot["cell"],
            "position_xy": center(view.frame, *robot["cell"]),
            "status": robot["status"],
            "waiting_for": robot.get("waiting_for"),
            "previous": robot["previous"],
            "goal": robot["goal"],
            "goal_node": goal_node,
            "radius": robot["radius"],
            "remaining": remaining,
            "remaining_xy": [center(view.frame, r, c) for r, c in remaining],
            "moves_done": min(robot["done"], len(robot["moves"])),
            "moves_total": len(robot["moves"]),
            "parked": bool(robot.get("parked")),
        }
        if view.poses is not None:
            entry["poses"] = [
                {"x": x, "y": y, "yaw": yaw} for x, y, yaw in view.poses.get(plan_id, ())
            ]
        out.append(entry)
    return FleetPublic.model_validate(
        {
            "fleet": view.fleet,
            "map_id": state["map_id"],
            "robot_radius": state["radius"],
            "roadmap": {"nodes": graph.nodes, "edges": graph.edges},
            "robots": out,
            "solve": state.get("solve") or {"status": "pending"},
        }
    )


def _step_poses(poses: Any, zones: planner.Zones | None) -> list[dict[str, float]]:
    """A step's poses, with ``"max_speed"`` inside a speed zone (looked up only on a map with
    speed zones: a step is the hot path)."""
    if zones is None or not zones.speed or not poses:
        return [{"x": x, "y": y, "yaw": yaw} for x, y, yaw in poses]
    caps = planner.speed_limits(zones, [(x, y) for x, y, _ in poses]).tolist()
    return _poses(poses, [None if math.isinf(v) else v for v in caps])


def center(frame: planner.MapFrame, row: int, col: int) -> list[float]:
    """``frame.centers([[row, col]]).round(6)[0].tolist()`` without the arrays: the same
    arithmetic on Python floats, rounded as ``numpy.round`` rounds (scale, round half to even,
    unscale)."""
    ox, oy, yaw = frame.origin
    u = (float(col) + 0.5) * frame.resolution
    v = (frame.shape[0] - 1 - float(row) + 0.5) * frame.resolution
    cos, sin = math.cos(yaw), math.sin(yaw)
    return [
        round((ox + cos * u - sin * v) * 1e6) / 1e6,
        round((oy + sin * u + cos * v) * 1e6) / 1e6,
    ]


def simulation_public(episode: planner.Episode) -> SimulationPublic:
    return SimulationPublic.model_validate(
        {
            "trajectory": episode.trajectory.tolist(),
            "metrics": {**episode.metrics, **meters(episode.trajectory, episode.plan.analysis)},
            "obstacle_motion": episode.obstacle_motion,
        }
    )


def _plan_fields(view: PlanView) -> dict[str, Any]:
    s = view.plan.summary()
    return {
        "plan_id": view.plan_id,
        "map_id": view.record["map_id"],
        "name": view.record.get("name"),
        "start": s["start"],
        "goal": s["goal"],
        "preset": s["preset"],
        "params": s["params"],
        "status": view.state.status,
        "narrow_fallback": view.state.narrow_fallback,
        "position": list(view.state.position),
        "position_xy": view.plan.analysis.frame.centers([view.state.position]).round(6)[0].tolist(),
        "analysis": {
            "gates": s["gates"],
            "tunnels": s["tunnels"],
            "narrow_fallback": s["narrow_fallback"],
            "cache_hit": view.record["cache_hit"],
            "analysis_ms": s["analysis_ms"],
        },
        "preview": {
            **{key: s[key] for key in PREVIEW_KEYS},
            "poses": _poses(s["poses"], s["max_speeds"], s["directions"]),
            "duration_s": s["duration_s"],
            "goal_used": _xy(s["goal_used"]),
            "waypoint_indices": s["waypoint_indices"],
            "narrowest": _narrowest(view.record.get("narrowest")),
            "passages": view.record.get("passages"),
            "detour": s["detour"] if s["detour"] is not None else view.record.get("detour"),
        },
        "waypoints": s["waypoints"],
    }


def _poses(
    poses: list[list[float]], speeds: list[float | None], directions: list[int] | None = None
) -> list[dict[str, float]]:
    """Poses as ``{"x", "y", "yaw"}``, ``"max_speed"`` inside a speed zone, and ``"direction"``
    when the plan drives a footprint or a car."""
    out: list[dict[str, float]] = []
    for i, ((x, y, yaw), speed) in enumerate(zip(poses, speeds, strict=True)):
        pose = {"x": x, "y": y, "yaw": yaw}
        if speed is not None:
            pose["max_speed"] = speed
        if directions is not None:
            pose["direction"] = directions[i]
        out.append(pose)
    return out


def _xy(point: list[float] | None) -> dict[str, float] | None:
    return None if point is None else {"x": point[0], "y": point[1]}


def _narrowest(point: list[float] | None) -> dict[str, float] | None:
    if point is None:
        return None
    x, y, width = (round(v, 6) for v in point)
    return {"x": x, "y": y, "width_m": width}


def passages_public(found: PassageSet) -> PassagesPublic:
    return PassagesPublic(
        passages=[
            PassagePublic(
                id=p.id,
                x=round(p.x, 6),
                y=round(p.y, 6),
                width_m=round(p.width_m, 6),
                length_m=round(p.length_m, 6),
            )
            for p in found.passages
        ],
        robot_radius=found.robot_radius,
        max_width=found.max_width,
    )


def nav_path(plan: planner.Plan, frame_id: str, now: float) -> dict[str, Any]:
    """The plan's poses as a rosbridge ``nav_msgs/Path`` (:class:`schemas.NavPath`), stamped
    ``now`` (seconds since the epoch), built directly: a path holds thousands of poses."""
    return planner.nav_msgs_path(plan.poses, frame_id, now)


def _point(xy: tuple[float, float] | None) -> dict[str, float] | None:
    """A point ``(x, y)`` as answers write points, ``{"x", "y"}``; None stays None."""
    return None if xy is None else {"x": xy[0], "y": xy[1]}

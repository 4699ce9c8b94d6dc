"""Presentation: what the resources return (planner objects) as the response models."""

from __future__ import annotations

from typing import Any

import numpy as np

import planner
from planner.planning import clearance_metrics
from schemas import MapPublic, PlanDetail, PlanPublic, SimulationPublic, StepPublic
from service.maps import MapView
from service.plans import PlanView

__all__ = ["map_public", "plan_detail", "plan_public", "simulation_public", "step_public"]

PREVIEW_KEYS = ("path", "length", "arc_cost", "min_clearance", "mean_clearance", "contact_ratio")


def map_public(view: MapView) -> MapPublic:
    h, w = view.grid.shape
    free = int(np.count_nonzero(view.grid == 0))
    plan = None if view.plan is None else plan_public(view.plan)
    return MapPublic(map_id=view.map_id, height=h, width=w, free_cells=free, plan=plan)


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
    }
    return PlanDetail.model_validate(
        {
            **_plan_fields(view),
            "iteration": state.iteration,
            "trajectory": trajectory.tolist(),
            "metrics": metrics,
        }
    )


def step_public(step: planner.Step) -> StepPublic:
    return StepPublic.model_validate(step.as_dict())


def simulation_public(episode: planner.Episode) -> SimulationPublic:
    return SimulationPublic.model_validate(
        {
            "trajectory": episode.trajectory.tolist(),
            "metrics": episode.metrics,
            "obstacle_motion": episode.obstacle_motion,
        }
    )


def _plan_fields(view: PlanView) -> dict[str, Any]:
    s = view.plan.summary()
    return {
        "plan_id": view.plan_id,
        "map_id": view.record["map_id"],
        "start": s["start"],
        "goal": s["goal"],
        "preset": s["preset"],
        "params": s["params"],
        "status": view.state.status,
        "narrow_fallback": view.state.narrow_fallback,
        "position": list(view.state.position),
        "analysis": {
            "gates": s["gates"],
            "tunnels": s["tunnels"],
            "narrow_fallback": s["narrow_fallback"],
            "cache_hit": view.record["cache_hit"],
            "analysis_ms": s["analysis_ms"],
        },
        "preview": {key: s[key] for key in PREVIEW_KEYS},
    }

"""What a stored plan's record keeps of a plan (its ends in meters, its route's legs), the plan
rebuilt from it over cached arrays, and the key of the arrays it depends on."""

from __future__ import annotations

from collections.abc import Hashable
from typing import Any

import planner
from service.stores import PlanRecord
from service.tenants import TENANT

__all__ = ["plan_ends", "plan_key", "plan_legs", "plan_of_record"]


def plan_key(record: PlanRecord) -> Hashable:
    """What a stored plan's arrays depend on: the tenant, map, start, goal, preset, parameters,
    narrow fallback and plainness of its record, and its ends in meters."""
    ends = record.get("ends") or {}
    return (
        TENANT.get(), record["map_id"], tuple(record["start"]), tuple(record["goal"]),
        record["preset"], tuple((k, _frozen(v)) for k, v in record["params"].items()),
        record["narrow_fallback"],
        record.get("plain", True),
        tuple((k, tuple(v) if isinstance(v, list) else v) for k, v in sorted(ends.items())),
        repr(record.get("legs")),
    )  # fmt: skip


def _frozen(value: Any) -> Any:
    """A parameter's value as a key: a footprint's vertices (lists once stored) as tuples."""
    return tuple(_frozen(v) for v in value) if isinstance(value, list | tuple) else value


def plan_ends(plan: planner.Plan) -> dict[str, Any]:
    """What a record keeps of a plan's ends in meters, to rebuild it (``Engine.plan_of``):
    the start and goal points as given, their yaws, the goal used within the tolerance."""

    def point(xy: tuple[float, float] | None) -> list[float] | None:
        return None if xy is None else [xy[0], xy[1]]

    return {
        "start_point": point(plan.start_point),
        "goal_point": point(plan.goal_point),
        "start_yaw": plan.start_yaw,
        "goal_yaw": plan.goal_yaw,
        "goal_used": point(plan.goal_used),
        "goal_tolerance": plan.goal_tolerance,
    }


def plan_legs(plan: planner.Plan) -> list[dict[str, Any]] | None:
    """What a record keeps of a route's legs (None: no waypoints), to rebuild each over its
    cached wave: its start and goal cells, narrow fallback, ends in meters and plain cost-to-go
    from its start (so that a step reads no other leg's wave)."""
    if plan.route is None:
        return None
    return [
        {
            "start": list(leg.start),
            "goal": list(leg.goal),
            "narrow_fallback": leg.narrow_fallback,
            "ends": plan_ends(leg),
            "cost": cost,
        }
        for leg, cost in zip(plan.route.legs, plan.route.costs, strict=True)
    ]


def plan_of_record(
    record: PlanRecord,
    params: planner.Params,
    analysis: planner.Analysis,
    wave: planner.Wave,
    search_seconds: float,
) -> planner.Plan:
    """A plan (or a route's leg) from its record, over its analysis and goal wave, its
    footprint's search given ``search_seconds``."""
    goal = record["goal"]
    ends = record.get("ends") or {}  # a record from before poses: the cells' centers

    def point(name: str) -> tuple[float, float] | None:
        xy = ends.get(name)
        return None if xy is None else (float(xy[0]), float(xy[1]))

    return planner.Plan(
        start=(record["start"][0], record["start"][1]),
        goal=(goal[0], goal[1]),
        preset=record["preset"],
        params=params,
        analysis=analysis,
        wave=wave,
        narrow_fallback=record["narrow_fallback"],
        elapsed_ms=0.0,
        start_point=point("start_point"),
        goal_point=point("goal_point"),
        start_yaw=ends.get("start_yaw"),
        goal_yaw=ends.get("goal_yaw"),
        goal_used=point("goal_used"),
        goal_tolerance=float(ends.get("goal_tolerance", 0.0)),
        search_seconds=search_seconds,
    )

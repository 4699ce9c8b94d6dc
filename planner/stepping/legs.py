"""A session through waypoints (``Plan.route``): the leg the robot is on, going on with the next
one at a waypoint, and the plain cost-to-go of the legs after it."""

from __future__ import annotations

from planner.plans.planning import Plan
from planner.stepping.state import SessionState

__all__ = ["go_on", "last_leg", "later_cost", "leg_of"]


def leg_of(plan: Plan, state: SessionState) -> Plan:
    """The leg the robot is on (``state.leg``); the plan itself when it has no waypoints."""
    if plan.route is None:
        return plan
    return plan.route.legs[min(state.leg, len(plan.route.legs) - 1)]


def last_leg(plan: Plan, state: SessionState) -> bool:
    """Whether the robot is on the leg to the goal (always, without waypoints)."""
    return plan.route is None or state.leg >= len(plan.route.legs) - 1


def go_on(plan: Plan, state: SessionState) -> bool:
    """At a waypoint (the current leg's goal) with legs left: on to the next leg, as many as end
    at that cell, with a fresh start (no detour, not held up, the tabu list from here); True
    when it went on."""
    went = False
    while not last_leg(plan, state) and state.position == leg_of(plan, state).goal:
        state.leg += 1
        state.leg_start = len(state.trajectory) - 1
        state.detour = []
        state.narrow_fallback = False
        state.held_up = state.replan_at = 0
        if state.status in ("arrived", "blocked"):
            state.status = "moving"
        went = True
    return went


def later_cost(plan: Plan, state: SessionState) -> float:
    """The plain cost-to-go ``k`` (cells) of the legs after the robot's, each from its start."""
    if plan.route is None:
        return 0.0
    return float(sum(plan.route.costs[state.leg + 1 :]))

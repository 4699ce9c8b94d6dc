"""Fleets (docs/fleets.md): a plan joining its fleet, a fleet robot's step among the others, and
the fleet as it stands. The fleet's state lives in the store beside its plans, and every change
to it is written at once with the plan that made it (``Store.put_fleet_plan``,
``Store.step_plan``): a step is load state (the plan's and the fleet's), decide, save both."""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import suppress
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

import planner
from planner import quote
from planner.fleets import (
    NO_TRAFFIC,
    YIELD_STEPS,
    Robot,
    WaitingZones,
    after_step,
    covering,
    traffic_for,
)
from planner.fleets import waiting_zones as planner_waiting_zones
from planner.plans.ends import cell_of
from service.errors import NotFound
from service.stores.base import FleetRecord
from service.tenants import scoped
from service.work.engine import Engine

__all__ = [
    "FleetView",
    "Moved",
    "empty",
    "get_fleet",
    "join",
    "moved_away",
    "step_in_fleet",
    "waiting_zones",
]


@dataclass(frozen=True, slots=True)
class FleetView:
    """A fleet's state, its map's frame and its passages (with their groups)."""

    fleet: str
    state: FleetRecord
    frame: planner.MapFrame
    zones: WaitingZones | None
    poses: dict[str, list[Any]] | None = None
    """With ``ahead``: each robot's path ahead (its last step's poses, ``(x, y, yaw)``)."""
    shape: tuple[int, int] = (0, 0)


@dataclass(frozen=True, slots=True)
class Moved:
    """A fleet robot's step: its answer, whom it waits for, and the fleet's new state."""

    step: planner.Step
    waiting_for: str | None
    fleet: FleetRecord


def empty(map_id: str, radius: float) -> FleetRecord:
    """A fleet with no robot yet, on ``map_id``, its passages for robots of ``radius``."""
    return {"map_id": map_id, "radius": float(radius), "next": 0, "robots": {}}


def moved_away(plan_id: str, fleet: str, map_id: str) -> planner.InvalidInput:
    """The error of a step whose fleet's name belongs to a fleet on another map now (its own
    fleet was gone, and the name taken again): ``FLEET_MAP_MISMATCH``, naming what to do."""
    msg = (
        f"FLEET_MAP_MISMATCH: fleet {quote(fleet)} of plan {quote(plan_id)} is on map "
        f"{quote(map_id)} now (the plan's fleet was gone and the name taken again); delete "
        "the plan and plan again"
    )
    return planner.InvalidInput(msg, field="fleet", code="FLEET_MAP_MISMATCH")


def join(
    fleet: str, plan_id: str, map_id: str, plan: planner.Plan
) -> Callable[[FleetRecord | None], FleetRecord]:
    """The fleet's new state with the plan's robot in it, from its state now (None: a new fleet
    on the plan's map, its radius the robot's). ``InvalidInput`` when the fleet is on another
    map (``FLEET_MAP_MISMATCH``) or another robot stands where the robot starts."""
    radius = float(plan.params.robot_radius)
    resolution = plan.analysis.frame.resolution

    def apply(state: FleetRecord | None) -> FleetRecord:
        if state is None or not state["robots"]:
            state = empty(map_id, radius)
        elif state["map_id"] != map_id:
            msg = (
                f"FLEET_MAP_MISMATCH: map_id {quote(map_id)} is not the map of fleet "
                f"{quote(fleet)} ({quote(state['map_id'])})"
            )
            raise planner.InvalidInput(msg, field="map_id", code="FLEET_MAP_MISMATCH")
        robots = {k: Robot.from_dict(v) for k, v in state["robots"].items()}
        taken = covering(plan.start, radius, robots, resolution=resolution)
        if taken:
            msg = (
                f"start {list(plan.start)} is taken: robot {quote(taken[0])} of fleet "
                f"{quote(fleet)} "
                "stands there (within the sum of both radii); delete its plan first"
            )
            raise planner.InvalidInput(msg, field="start", code="FLEET_START_TAKEN")
        robot = Robot(state["next"], plan.start, plan.start, radius, plan.goal)
        return {
            **state,
            "next": state["next"] + 1,
            "robots": {**state["robots"], plan_id: robot.as_dict()},
        }

    return apply


async def step_in_fleet(
    engine: Engine,
    plan_id: str,
    session: planner.Session,
    obstacles: list[list[int]] | npt.NDArray[np.int64],
    fleet: FleetRecord,
    *,
    position: Any,
    seq: int | None,
) -> Moved:
    """The robot's step, keeping clear of its fleet: the other robots (their cells and targets,
    with both radii) and the passages another robot holds are obstacles besides the client's.
    A robot told to wait next to a passage closed to it steps again with the passage open (on
    its state from before): if it would enter, it waits at it (``wants``), and robots of lower
    priority let it go first. Held up beside a waiting robot of lower priority, it puts off
    searching its way round (``YIELD_STEPS``): that one searches first."""
    plan = session.plan
    frame = plan.analysis.frame
    mine = fleet["robots"].get(plan_id)
    if mine is not None and position is None and session.at_goal:
        return await _on_goal(engine, plan_id, session, obstacles, fleet, seq=seq)
    robots = {k: Robot.from_dict(v) for k, v in fleet["robots"].items()}
    me = robots.get(plan_id)
    if me is None:  # its fleet expired meanwhile: it joins again, last
        cell = session.state.position
        me = Robot(
            int(fleet.get("next", 0)), cell, cell, float(plan.params.robot_radius), plan.goal
        )
        robots[plan_id] = me
        fleet = {**fleet, "next": int(fleet.get("next", 0)) + 1}
    zones = await waiting_zones(engine, fleet["map_id"], float(fleet["radius"]))
    margin = plan.params.dynamic_margin
    here = None
    if position is not None:
        with suppress(planner.InvalidInput):  # else the step refuses it
            here = cell_of(plan.analysis, position, "position")
    traffic = traffic_for(
        plan_id, robots, resolution=frame.resolution, shape=plan.analysis.shape, zones=zones,
        here=here, margin=margin, within=_nearby(plan),
    )  # fmt: skip
    given = np.asarray(obstacles, dtype=np.int64).reshape(-1, 2)
    st = session.state
    if traffic.beside_waiter and st.held_up < YIELD_STEPS * max(plan.params.patience, 1):
        # Held up beside a waiting robot of lower priority: that one searches first.
        st.replan_at = max(st.replan_at, st.held_up + 1)
    before = None
    near = here or me.target
    if traffic.closed and zones is not None and zones.near(near, list(traffic.closed), margin + 2):
        before = session.state.copy()
    step = await engine.step(session, traffic.obstacles(given), position=position, seq=seq)
    would_enter = None
    if before is not None and zones is not None and step.status == "waiting":
        # Waiting next to a passage closed to it: the step again with the passages open. Had it
        # gone on, toward a closed one, it waits at it.
        trial = planner.Session(session.route, before, poses=False)
        tried = await engine.step(
            trial, traffic.obstacles(given, open_zones=True), position=position, seq=seq
        )
        for group in traffic.closed if tried.position != tried.previous else ():
            if zones.near(tried.position, [group], margin):
                would_enter = group
                break
    moved = after_step(
        me, previous=step.previous, position=step.position, status=step.status,
        traffic=traffic, zones=zones, would_enter=would_enter,
    )  # fmt: skip
    state = {**fleet, "robots": {**fleet["robots"], plan_id: moved.as_dict()}}
    return Moved(step, moved.waiting_for, state)


async def _on_goal(
    engine: Engine,
    plan_id: str,
    session: planner.Session,
    obstacles: list[list[int]] | npt.NDArray[np.int64],
    fleet: FleetRecord,
    *,
    seq: int | None,
) -> Moved:
    """The step of a robot on its goal: it stays whatever the others do (its answer reads no
    obstacle but the client's, checked), so the fleet's traffic is not worked out; the fleet
    records it there."""
    me = Robot.from_dict(fleet["robots"][plan_id])
    zones = await waiting_zones(engine, fleet["map_id"], float(fleet["radius"]))
    step = await engine.step(session, obstacles, position=None, seq=seq)
    moved = after_step(
        me, previous=step.previous, position=step.position, status=step.status,
        traffic=NO_TRAFFIC, zones=zones,
    )  # fmt: skip
    state = {**fleet, "robots": {**fleet["robots"], plan_id: moved.as_dict()}}
    return Moved(step, moved.waiting_for, state)


async def waiting_zones(engine: Engine, map_id: str, robot_radius: float) -> WaitingZones:
    """The passages' waiting zones of a fleet's map for its robots' radius: found once per map
    and radius, in the pool, and kept in the analysis cache."""

    async def compute() -> WaitingZones:
        robot_map = await engine.robot_map(map_id)
        return await engine.pool.run(_waiting_zones, robot_map, robot_radius)

    key = ("waiting zones", scoped(map_id), float(robot_radius))
    zones, _ = await engine.cache.get_or_compute(key, compute)
    assert isinstance(zones, WaitingZones)
    return zones


def _waiting_zones(robot_map: planner.RobotMap, robot_radius: float) -> WaitingZones:
    space = planner.configuration_space(robot_map, robot_radius=robot_radius)
    passages = planner.find_passages(robot_map, robot_radius)
    return planner_waiting_zones(
        space.traversable, passages, resolution=robot_map.resolution, robot_radius=robot_radius
    )


NEARBY_M = 3.0
"""Meters (and the plan's ``horizon_m``, if longer) within which a step sees the fleet's other
robots as obstacles; farther ones cannot meet it this step."""


def _nearby(plan: planner.Plan) -> int:
    """:data:`NEARBY_M` (or the path ahead's ``horizon_m``, and a meter) in cells."""
    meters = max(NEARBY_M, float(plan.params.horizon_m) + 1.0)
    return math.ceil(meters / plan.analysis.frame.resolution)


async def get_fleet(engine: Engine, fleet: str, *, ahead: bool = False) -> FleetView:
    """The fleet's state now (with ``ahead``, each robot's path ahead read from its plan);
    ``NotFound`` when it has no robot."""
    state = await engine.store.get_fleet(fleet)
    if state is None or not state["robots"]:
        msg = f"fleet: no fleet {quote(fleet)} (no plan of it is alive)"
        raise NotFound(msg, field="fleet")
    robot_map = await engine.robot_map(state["map_id"])
    zones = await waiting_zones(engine, state["map_id"], float(state["radius"]))
    poses: dict[str, list[Any]] | None = None
    if ahead:
        poses = {}
        for plan_id in state["robots"]:
            record = await engine.store.get_plan(plan_id)
            last = None if record is None else record["state"].get("last_step")
            poses[plan_id] = [] if last is None else list(last.get("poses") or ())
    return FleetView(fleet, state, robot_map.frame, zones, poses, robot_map.shape)

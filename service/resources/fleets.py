"""Fleets (docs/fleets.md): robots of one map planned together on a roadmap and executed in
order. A plan joins its fleet (which marks it to be solved again); a fleet robot's step loads
the fleet, records the robot's progress, solves the fleet again if it changed, and answers the
moves whose predecessors are done. The fleet's state lives in the store beside its plans and is
written at once with the stepping robot's plan (``Store.put_fleet_plan``, ``Store.step_plan``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

import planner
from planner import quote
from planner.fleets import Schedule, attach, build_roadmap, schedule, segment_distances
from planner.plans.ends import cell_of
from service.errors import NotFound
from service.resources.fleet_moves import advance
from service.resources.fleet_solve import FleetMap, chain, node_cell, resolve
from service.resources.mapf_size import check_size
from service.stores.base import FleetRecord, Update
from service.tenants import scoped
from service.work.engine import Engine

__all__ = [
    "FleetView",
    "Moved",
    "empty",
    "fleet_map",
    "fleet_robot",
    "get_fleet",
    "join",
    "moved_away",
    "retarget",
    "solve_now",
    "step_in_fleet",
]


@dataclass(frozen=True, slots=True)
class FleetView:
    """A fleet's state, its map's frame and its roadmap."""

    fleet: str
    state: FleetRecord
    frame: planner.MapFrame
    fleet_map: FleetMap
    shape: tuple[int, int] = (0, 0)
    poses: dict[str, list[Any]] | None = None
    """With ``ahead``: each robot's path ahead (its last step's poses, ``(x, y, yaw)``)."""


@dataclass(frozen=True, slots=True)
class Moved:
    """A fleet robot's step: its answer, whom it waits for, and the fleet's new state."""

    step: planner.Step
    waiting_for: str | None
    fleet: FleetRecord


def fleet_robot(params: dict[str, Any]) -> dict[str, Any]:
    """A fleet robot's planner parameters: with a ``footprint``, its enclosing circle's radius
    in place of it (the roadmap keeps round robots apart). Its moves are the roadmap's: a car
    motion is refused."""
    if params.get("motion", "diff") != "diff":
        msg = (
            f"motion {quote(params['motion'])}: a fleet robot moves along the fleet's roadmap "
            "and turns in place; plan a car alone"
        )
        raise planner.InvalidInput(msg, field="motion")
    if params.get("footprint") is None:
        return params
    radius = planner.footprint_of(params["footprint"]).circumscribed_radius
    out = {k: v for k, v in params.items() if k != "footprint"}
    out["robot_radius"] = radius
    return out


def empty(map_id: str, plan: planner.Plan) -> FleetRecord:
    """A fleet with no robot yet, on ``map_id``, for robots up to ``plan``'s radius, its roadmap's
    costs those of ``plan``'s preset."""
    return {
        "map_id": map_id,
        "radius": float(plan.params.robot_radius),
        "params": plan.params.as_dict(),
        "next": 0,
        "robots": {},
        "dirty": True,
    }


async def fleet_map(engine: Engine, fleet: FleetRecord) -> FleetMap:
    """The fleet's roadmap (built once per map, radius and preset, in the pool, cached with the
    analyses) and the analysis it stands on."""
    params = planner.Params(**{**fleet["params"], "robot_radius": float(fleet["radius"])})
    analysis, _ = await engine.analysis(fleet["map_id"], params)
    wide = params.clean_weight > 0 or params.wall_cost != "cells"

    async def compute() -> _Sized:
        graph = await engine.pool.run(
            build_roadmap, analysis, radius=params.robot_radius, wide=wide
        )
        return _Sized(FleetMap(graph, analysis, graph.pieces()), int(graph.cells.nbytes * 5))

    key = ("roadmap", scoped(fleet["map_id"]), analysis.params_key, params.robot_radius, wide)
    found, _ = await engine.cache.get_or_compute(key, compute)
    assert isinstance(found.value, FleetMap)
    return found.value


@dataclass(frozen=True, slots=True)
class _Sized:
    """A cached value and the bytes it is charged (the cache's ``Sized``)."""

    value: Any
    nbytes: int


def join(
    fleet: str,
    plan_id: str,
    map_id: str,
    plan: planner.Plan,
    fmap: FleetMap | None,
    *,
    most: int = 500,
    name: str | None = None,
) -> Any:
    """The fleet's new state with the plan's robot in it (marked to be solved again), from its
    state now (None: a new fleet). ``InvalidInput`` when the fleet is on another map
    (``FLEET_MAP_MISMATCH``), the robot is larger than the fleet's roadmap allows
    (``FLEET_RADIUS``), another robot stands within both radii of its start or its way onto the
    roadmap (``FLEET_START_TAKEN``), its goal is another robot's (``FLEET_GOAL_TAKEN``), or the
    fleet has ``most`` robots (``FLEET_FULL``) or more than its solver's tables allow here."""
    radius = float(plan.params.robot_radius)

    def apply(state: FleetRecord | None) -> FleetRecord:
        if state is None or not state["robots"]:
            state = empty(map_id, plan)
        elif state["map_id"] != map_id:
            msg = (
                f"FLEET_MAP_MISMATCH: map_id {quote(map_id)} is not the map of fleet "
                f"{quote(fleet)} ({quote(state['map_id'])})"
            )
            raise planner.InvalidInput(msg, field="map_id", code="FLEET_MAP_MISMATCH")
        if radius > float(state["radius"]) + 1e-9:
            msg = (
                f"FLEET_RADIUS: robot_radius {radius} is larger than the radius fleet "
                f"{quote(fleet)} was planned for ({state['radius']}, its first robot's): "
                "create the largest robot first, or use another fleet"
            )
            raise planner.InvalidInput(msg, field="params.robot_radius", code="FLEET_RADIUS")
        if fmap is None:
            raise AssertionError("a fleet's roadmap is found before a robot joins")
        count = len(state["robots"]) + 1
        if count > most:
            msg = f"FLEET_FULL: fleet {quote(fleet)} has {most} robots, PLANNER_MAX_FLEET_ROBOTS"
            raise planner.InvalidInput(msg, field="fleet", code="FLEET_FULL")
        check_size(count, fmap.graph, "fleet")
        robot = _new_robot(state, plan, fmap)
        if name is not None:  # the plan's name, for the fleet's page and answer
            robot["name"] = name
        _check_free(fleet, state, robot, fmap)
        return {
            **state,
            "next": state["next"] + 1,
            "dirty": True,
            "robots": {**state["robots"], plan_id: robot},
        }

    return apply


def _new_robot(state: FleetRecord, plan: planner.Plan, fmap: FleetMap) -> dict[str, Any]:
    graph = fmap.graph
    start, goal = [int(v) for v in plan.start], [int(v) for v in plan.goal]
    at = int(graph.node_of([start])[0])
    # Its goal joins the nearest node that no other robot's goal joins.
    others = {int(r["goal_node"]) for r in state["robots"].values()}
    goal_node = attach(graph, fmap.analysis, goal, exclude=others)
    if goal_node < 0:
        msg = f"goal {goal} has no node of the fleet's roadmap in reach by a straight move"
        raise planner.InvalidInput(msg, field="goal", code="NO_VALID_PATH")
    joins = at if at >= 0 else attach(graph, fmap.analysis, start)
    if joins < 0 or fmap.pieces[joins] != fmap.pieces[goal_node]:
        msg = (
            f"NO_VALID_PATH: goal {goal} cannot be reached from start {start} on the fleet's "
            "roadmap (robots of its radius kept apart cannot get there)"
        )
        raise planner.InvalidInput(msg, field="goal", code="NO_VALID_PATH")
    return {
        "rank": int(state["next"]),
        "radius": float(plan.params.robot_radius),
        "cell": start,
        "previous": start,
        "goal": goal,
        "goal_node": goal_node,
        "node": at,
        "moves": [],
        "done": 0,
        "told": 0,
        "status": "ready",
        "waiting_for": None,
        "seen": time.time(),
    }


def _check_free(
    fleet: str, state: FleetRecord, robot: dict[str, Any], fmap: FleetMap, *, start: bool = True
) -> None:
    """``FLEET_GOAL_TAKEN`` when another robot's goal is within both radii of the robot's; with
    ``start``, ``FLEET_START_TAKEN`` when another robot may be within both radii of its cell."""
    res = fmap.graph.resolution
    extras = state.get("extras", [])
    goal = np.array(robot["goal"], dtype=np.float64)
    here = np.array(robot["cell"], dtype=np.float64)
    for plan_id, other in state["robots"].items():
        reach = (robot["radius"] + float(other["radius"])) / res
        if np.linalg.norm(np.array(other["goal"], dtype=np.float64) - goal) < reach:
            msg = (
                f"FLEET_GOAL_TAKEN: goal {robot['goal']} is robot {quote(plan_id)}'s goal in "
                f"fleet {quote(fleet)} (within the sum of both radii): choose another"
            )
            raise planner.InvalidInput(msg, field="goal", code="FLEET_GOAL_TAKEN")
        cells = np.array(
            [node_cell(n, other, extras, fmap.graph) for n in chain(other)], dtype=np.float64
        )
        if start and np.min(np.linalg.norm(cells - here, axis=1)) < max(reach, 1e-9):
            msg = (
                f"start {robot['cell']} is taken: robot {quote(plan_id)} of fleet "
                f"{quote(fleet)} stands there (within the sum of both radii); delete its plan "
                "first"
            )
            raise planner.InvalidInput(msg, field="start", code="FLEET_START_TAKEN")


def retarget(
    fleet_name: str, state: FleetRecord, plan_id: str, goal: list[int], fmap: FleetMap
) -> FleetRecord:
    """The fleet with ``plan_id``'s robot going to ``goal`` (its node: the nearest no other
    robot's goal joins), marked to be solved again; ``FLEET_GOAL_TAKEN`` when the goal is
    within both radii of another robot's goal."""
    robots = {k: v for k, v in state["robots"].items() if k != plan_id}
    me = dict(state["robots"][plan_id])
    node = attach(
        fmap.graph, fmap.analysis, goal, exclude={int(r["goal_node"]) for r in robots.values()}
    )
    if node < 0:
        msg = f"goal {goal} has no node of the fleet's roadmap in reach by a straight move"
        raise planner.InvalidInput(msg, field="goal", code="NO_VALID_PATH")
    me.update(goal=goal, goal_node=node, arrived=False)
    _check_free(fleet_name, {**state, "robots": robots}, me, fmap, start=False)
    return {**state, "dirty": True, "robots": {**state["robots"], plan_id: me}}


def moved_away(plan_id: str, fleet: str, map_id: str) -> planner.InvalidInput:
    """The error of a step whose fleet's name belongs to a fleet on another map now (its own
    fleet was gone, and the name taken again): ``FLEET_MAP_MISMATCH``, naming what to do."""
    msg = (
        f"FLEET_MAP_MISMATCH: fleet {quote(fleet)} of plan {quote(plan_id)} is on map "
        f"{quote(map_id)} now (the plan's fleet was gone and the name taken again); delete "
        "the plan and plan again"
    )
    return planner.InvalidInput(msg, field="fleet", code="FLEET_MAP_MISMATCH")


async def step_in_fleet(
    engine: Engine,
    plan_id: str,
    session: planner.Session,
    obstacles: Any,
    fleet: FleetRecord,
    *,
    position: Any,
    seq: int | None,
) -> Moved:
    """Load (the fleet as read), decide (progress, leases, a new joint plan if the fleet
    changed, the moves now allowed), and hand back the fleet's new state to save."""
    plan, st = session.plan, session.state
    if seq is not None and st.last_seq is not None and seq != st.last_seq + 1:
        msg = f"seq {seq} does not follow the last step's seq {st.last_seq}"
        raise planner.SequenceConflict(msg, field="seq")
    fmap = await fleet_map(engine, fleet)
    now = time.time()
    # Copied on write: the robots this step changes are copied, the others shared.
    state: FleetRecord = {**fleet, "robots": dict(fleet["robots"])}
    robots = state["robots"]
    if plan_id not in robots:  # its fleet expired meanwhile: it joins again, last
        robot = _new_robot(state, plan, fmap)
        robot["cell"] = list(st.position)
        robot["node"] = int(fmap.graph.node_of([st.position])[0])
        robots[plan_id] = robot
        state["next"] = int(state["next"]) + 1
        state["dirty"] = True
    me = robots[plan_id] = dict(robots[plan_id])
    here = None if position is None else cell_of(plan.analysis, position, "position")
    if _progress(me, here, fmap, state, plan):
        state["dirty"] = True
    if me.get("parked"):
        me["parked"] = False
        state["dirty"] = True
    me["seen"] = now
    lease = engine.settings.fleet_lease_seconds
    for k, other in list(robots.items()):  # the others' leases
        if k != plan_id and not other.get("parked") and now - float(other.get("seen", now)) > lease:
            robots[k] = {**other, "parked": True}
            state["dirty"] = True
    blocked = state.get("blocked", {})
    if any(t <= now for t in blocked.values()):
        state["blocked"] = {n: t for n, t in blocked.items() if t > now}
    if state.get("dirty") and _may_solve(state, now, engine.settings.fleet_solve_seconds):
        state = await engine.pool.run(
            resolve, state, fmap, time_limit_s=engine.settings.fleet_solve_seconds,
            seed=int(state["next"]),
        )  # fmt: skip
    plan_of = await _schedule(engine, state, fmap)
    step, waiting_for = advance(
        plan_id, state, plan_of, fmap, session, obstacles, position=position, here=here, seq=seq,
        now=now, lease=lease,
    )  # fmt: skip
    return Moved(step, waiting_for, state)


async def solve_now(engine: Engine, plan_id: str) -> None:
    """Solve the plan's fleet again at once if it changed (a robot joining): its robots'
    next steps then find the joint plan made, rather than the first of them making it while
    the others wait behind it. Written with the plan's record as a step's would be."""

    async def decide(record: dict[str, Any], fleet: FleetRecord | None) -> Update[None]:
        now = time.time()
        budget = engine.settings.fleet_solve_seconds
        if fleet is None or not fleet.get("dirty") or not _may_solve(fleet, now, budget):
            return Update(None)
        fmap = await fleet_map(engine, fleet)
        seed = int(fleet["next"])
        state = await engine.pool.run(resolve, fleet, fmap, time_limit_s=budget, seed=seed)
        return Update(None, record, fleet=state)

    await engine.store.step_plan(plan_id, decide)


def _may_solve(state: FleetRecord, now: float, budget: float) -> bool:
    """A fleet whose last solve failed is tried again only after a while (twice its budget, at
    least a second): every step would otherwise wait for the solver to fail again."""
    failed = state.get("failed_at")
    return failed is None or now - float(failed) >= max(1.0, 2.0 * budget)


def _progress(
    me: dict[str, Any],
    here: tuple[int, int] | None,
    fmap: FleetMap,
    state: FleetRecord,
    plan: planner.Plan,
) -> bool:
    """Record the moves the robot did: all it was told when it reports nothing, else as far
    along its told moves as it is (within ``deviation_m``). True when it is off its plan (it is
    then recorded where it is, off the roadmap, and the fleet must be solved again)."""
    if here is None:
        me["done"] = max(me["done"], me["told"])
        return False
    nodes = chain(me)
    cells = np.array(
        [node_cell(n, me, state.get("extras", []), fmap.graph) for n in nodes], dtype=np.float64
    )
    point = np.array(here, dtype=np.float64)
    distances = np.linalg.norm(cells - point, axis=1)
    tolerance = max(1.0, float(plan.params.deviation_m) / fmap.graph.resolution)
    if distances.min() <= tolerance:
        me["done"] = me["done"] + int(np.nonzero(distances <= tolerance)[0].max())
        return False
    if len(cells) > 1:
        along = segment_distances(point, point, cells[:-1], cells[1:])
        if along.min() <= tolerance:
            me["done"] = me["done"] + int(np.argmin(along))
            return False
    me.update(cell=list(here), node=int(fmap.graph.node_of([here])[0]), moves=[], done=0, told=0)
    return True


async def _schedule(engine: Engine, state: FleetRecord, fmap: FleetMap) -> Schedule | None:
    """The joint plan's dependency graph, made once per solve on each replica."""
    if "solve_id" not in state:
        return None
    robots = state["robots"]

    async def compute() -> _Sized:
        return _Sized(_rebuild(state, fmap), 64 * sum(len(r["moves"]) + 1 for r in robots.values()))

    key = ("fleet schedule", state["solve_id"])
    found, _ = await engine.cache.get_or_compute(key, compute)
    assert isinstance(found.value, Schedule)
    return found.value


def _rebuild(state: FleetRecord, fmap: FleetMap) -> Schedule:
    """The schedule of the fleet's last solve from its robots' moves (as stored)."""
    robots = state["robots"]
    graph = fmap.graph
    extras = np.array(state.get("extras", []), dtype=np.float64).reshape(-1, 2)
    points = np.concatenate([graph.cells.astype(np.float64), extras])
    moves = [robots[k]["moves"] if k in robots else [] for k in state.get("agents", [])]
    reach = 2.0 * float(state["radius"]) / graph.resolution
    return schedule(moves, points, roadmap_nodes=graph.nodes, reach=reach)


async def get_fleet(engine: Engine, fleet: str, *, ahead: bool = False) -> FleetView:
    """The fleet's state now (with ``ahead``, each robot's path ahead read from its plan);
    ``NotFound`` when it has no robot."""
    state = await engine.store.get_fleet(fleet)
    if state is None or not state["robots"] or "params" not in state:
        msg = f"fleet: no fleet {quote(fleet)} (no plan of it is alive)"
        raise NotFound(msg, field="fleet")
    robot_map = await engine.robot_map(state["map_id"])
    fmap = await fleet_map(engine, state)
    poses: dict[str, list[Any]] | None = None
    if ahead:
        poses = {}
        for plan_id in state["robots"]:
            record = await engine.store.get_plan(plan_id)
            last = None if record is None else record["state"].get("last_step")
            poses[plan_id] = [] if last is None else list(last.get("poses") or ())
    return FleetView(fleet, state, robot_map.frame, fmap, robot_map.shape, poses)

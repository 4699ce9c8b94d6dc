"""Plans and steps: create a plan, read it, forget it, and step the robot along it.

A step is load state, decide, save state: the plan's record holds its resolved parameters and
whether it took the narrow fallback, so the step finds the plan's arrays in the cache by key
and calls the planner's session step, with nothing resolved or rebuilt on the way.
"""

from __future__ import annotations

import secrets
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

import planner
from planner import quote
from planner.plans.ends import free_cell
from schemas import PlanCreate, Point, StepCreate
from service.errors import NotFound
from service.resources import fleets, live, passages
from service.resources.bodies import overrides, where
from service.stores import PlanRecord
from service.stores.base import Event, FleetRecord, Update, unknown_map
from service.work.engine import Engine
from service.work.pictures import cell_size, frame_map
from service.work.records import plan_ends, plan_legs

__all__ = [
    "PlanView",
    "StepView",
    "change_goal",
    "create_plan",
    "delete_plan",
    "get_plan",
    "plan_path",
    "render_plan",
    "require",
    "step",
]


Obstacles = list[list[int]] | npt.NDArray[np.int64]
"""A step's blocked cells: JSON's lists as given, or an ``(n, 2)`` array once circles are in."""


@dataclass(frozen=True, slots=True)
class PlanView:
    """A stored plan with its arrays and the robot's state: what a response is made of."""

    plan_id: str
    record: PlanRecord
    plan: planner.Plan
    state: planner.SessionState


@dataclass(frozen=True, slots=True)
class StepView:
    """A step's answer, the plan's frame (for the answer's meters) and every cell the client's
    dynamic obstacles blocked (circles as the cells they cover; the live layer's marks are
    read on their own, ``GET /maps/{map_id}/live``)."""

    step: planner.Step
    frame: planner.MapFrame
    obstacles: Obstacles
    replayed: bool = False
    """The answer of a retried ``seq``: nothing moved, nothing was written or published."""
    zones: planner.Zones | None = None
    """The map's zones: a pose inside a speed zone carries its ``max_speed``."""
    waiting_for: str | None = None
    """A fleet robot waiting: the plan_id of the robot it waits for."""


async def create_plan(engine: Engine, body: PlanCreate) -> PlanView:
    params = overrides(body) if body.fleet is None else fleets.fleet_robot(overrides(body))
    plan, cache_hit = await engine.build_plan(
        body.map_id, where(body.start), where(body.goal), body.preset, params,
        goal_tolerance=body.goal_tolerance,
        waypoints=[where(point) for point in body.waypoints],
    )  # fmt: skip
    plan_id = secrets.token_hex(16)
    state = planner.Session(plan).state
    stored = state.as_dict()
    record: PlanRecord = {
        "map_id": body.map_id,
        "start": list(plan.start),
        "goal": list(plan.goal),
        "preset": plan.preset,
        "params": plan.params.as_dict(),
        "narrow_fallback": plan.narrow_fallback,
        "plain": plan.analysis.plain,
        "ends": plan_ends(plan),
        "legs": plan_legs(plan),
        "cache_hit": cache_hit,
        "state": stored,
        "detour": plan.summary()["detour"],  # a plan rebuilt from its record has none
        **await passages.crossings(engine, body.map_id, plan),
    }
    if body.name is not None:
        record["name"] = body.name
    append = stored.pop("trajectory")
    if body.fleet is None:
        await engine.store.put_plan(plan_id, record, append=append)
    else:
        record["fleet"] = body.fleet
        # The fleet's roadmap found now, in the pool (a new fleet's for this robot): its goal
        # joins a node, and the fleet's first step does not wait for it.
        now = await engine.store.get_fleet(body.fleet)
        if now is None or not now["robots"] or now["map_id"] != body.map_id:
            now = fleets.empty(body.map_id, plan)
        fmap = await fleets.fleet_map(engine, now)
        most = engine.settings.max_fleet_robots
        joined = fleets.join(
            body.fleet, plan_id, body.map_id, plan, fmap, most=most, name=body.name
        )
        await engine.store.put_fleet_plan(plan_id, record, joined, append=append)
        await fleets.solve_now(engine, plan_id)
    return PlanView(plan_id, record, plan, state)


async def get_plan(engine: Engine, plan_id: str) -> PlanView:
    """The plan and the robot's whole state, its trajectory read back from the store's log."""
    record = await _record(engine, plan_id)
    plan = await engine.plan_of(record, preview=True)
    # A log lost on its own (never written with its record) still shows where the robot is.
    trajectory = await engine.store.get_trajectory(plan_id) or [record["state"]["position"]]
    state = planner.SessionState.from_dict({**record["state"], "trajectory": trajectory})
    return PlanView(plan_id, record, plan, state)


async def change_goal(engine: Engine, plan_id: str, goal: Any) -> PlanView:
    """A fleet robot's new goal (docs/fleets.md): its record's plan goes there from its start
    (for ``GET /plan``), and its fleet, marked, is solved again at its next step."""
    record = await _record(engine, plan_id)
    if "fleet" not in record:
        msg = (
            f"goal: plan {quote(plan_id)} is in no fleet; a lone robot's new goal is a new "
            "plan (POST /plan from where it is)"
        )
        raise planner.InvalidInput(msg, field="goal")
    plan = await engine.plan_of(record)
    cell = list(free_cell(plan.analysis, goal, "goal"))
    new, _ = await engine.build_plan(
        record["map_id"], tuple(record["start"]), tuple(cell), record["preset"], record["params"]
    )

    async def decide(record: PlanRecord, fleet: FleetRecord | None) -> Update[None]:
        if fleet is None or plan_id not in fleet["robots"]:
            raise _unknown_plan(plan_id)
        fmap = await fleets.fleet_map(engine, fleet)
        state = fleets.retarget(record["fleet"], fleet, plan_id, cell, fmap)
        changed = {
            **record, "goal": cell, "ends": plan_ends(new), "legs": plan_legs(new),
            "narrow_fallback": new.narrow_fallback,
        }  # fmt: skip
        return Update(None, changed, fleet=state)

    if await engine.store.step_plan(plan_id, decide) is None:
        raise _unknown_plan(plan_id)
    return await get_plan(engine, plan_id)


async def delete_plan(engine: Engine, plan_id: str) -> None:
    if not await engine.store.delete_plan(plan_id):
        raise _unknown_plan(plan_id)


async def step(
    engine: Engine,
    plan_id: str,
    body: StepCreate,
    event: Callable[[StepView], Event] | None = None,
) -> StepView:
    """Load the robot's state, decide its move, save the state: one
    :meth:`~service.stores.Store.update_plan`, so concurrent steps never lose a move. A
    ``position`` point means the cell containing it; a circle obstacle, the cells it covers
    (:func:`planner.circle_cells`, with the robot's radius). ``event``, when given, makes the
    step's event for the live viewer, which the store publishes with its write (a store that
    :attr:`~service.stores.Store.publishes`)."""
    limit = engine.settings.max_dynamic_obstacles
    if len(body.dynamic_obstacles) > limit:
        msg = f"{len(body.dynamic_obstacles)} dynamic obstacles given; the limit is {limit}"
        raise planner.InvalidInput(msg, field="dynamic_obstacles")

    async def decide(record: PlanRecord, fleet: FleetRecord | None) -> Update[StepView]:
        plan = await engine.plan_of(record)
        # The trajectory log is read only for the paper's tabu list: the wide decision needs
        # none of it, and its step then costs the same at any length of episode.
        state = planner.SessionState.from_dict(record["state"])  # stored without trajectory
        if plan.params.decision == "paper":
            state.trajectory = await engine.store.get_trajectory(plan_id)
        else:
            state.trajectory = [state.position]
        known = len(state.trajectory)
        session = planner.Session(plan, state)
        frame = plan.analysis.frame
        # A point goes as sent: a refusal quotes it.
        position: Any = body.position
        if isinstance(position, Point):
            position = position.model_dump(exclude_none=True)
        if _circle_rows(plan, body.dynamic_obstacles) > CIRCLE_ROWS_ON_LOOP:
            # Off the event loop: the kernel then runs without the GIL, and the request's
            # deadline can stop the step here, before anything is written.
            obstacles = await engine.pool.run_step(_obstacle_cells, plan, body.dynamic_obstacles)
        else:
            obstacles = _obstacle_cells(plan, body.dynamic_obstacles)
        replayed = body.seq is not None and body.seq == state.last_seq
        client_cells = obstacles  # the client's, which the viewer draws (the marks: GET /live)
        digest = ""  # the marks decided on, which the write checks
        if not replayed:  # the live layer's marks: obstacles like the client's (docs/live.md)
            here = (state.position[0], state.position[1])
            marks, digest = await live.step_marks(engine, record["map_id"], plan, body, here)
            obstacles = live.with_marks(obstacles, marks)
        waiting_for, new_fleet = None, None
        if fleet is not None and "params" not in fleet:
            fleet = None  # a fleet of an older version: its robots join a new one as they step
        if "fleet" in record and fleet is None:
            # Its fleet's state expired: it starts again (the write is fenced on its absence).
            fleet = fleets.empty(record["map_id"], plan)
        elif fleet is not None and fleet["map_id"] != record["map_id"]:
            # The name is another map's fleet now: never written over. A replica's stale copy
            # is read again by the store, which then decides again on the fleet as it is.
            raise fleets.moved_away(plan_id, record["fleet"], fleet["map_id"])
        if replayed or fleet is None:
            # Here when it cannot search, else on the steps' own workers (see Engine.step).
            result = await engine.step(session, obstacles, position=position, seq=body.seq)
        else:
            moved = await fleets.step_in_fleet(
                engine, plan_id, session, obstacles, fleet, position=position, seq=body.seq
            )
            result, waiting_for, new_fleet = moved.step, moved.waiting_for, moved.fleet
        if replayed:  # the robot did not move again: nothing to write, no event to send
            if fleet is not None:
                waiting_for = fleet["robots"].get(plan_id, {}).get("waiting_for")
            return Update(
                StepView(result, frame, client_cells, True, plan.analysis.zones, waiting_for)
            )
        stored = session.state.as_dict()
        appended = stored.pop("trajectory")[known:]
        view = StepView(
            result, frame, client_cells, zones=plan.analysis.zones, waiting_for=waiting_for
        )
        message = None if event is None else event(view)
        return Update(view, {**record, "state": stored}, appended, message, new_fleet, digest)

    # Written only if the plan still exists: a DELETE that won the race stays a delete.
    update = await engine.store.step_plan(plan_id, decide)
    if update is None:
        raise _unknown_plan(plan_id)
    return update.answer


CIRCLE_ROWS_ON_LOOP = 2048
"""Map rows a step's circles may span in all and still be rasterised on the event loop
(a millisecond or so); beyond, a step worker does it."""


def _circle_rows(plan: planner.Plan, given: list[Any]) -> float:
    """The map rows the step's circles span in all (each at most the map's height): what
    rasterising them costs."""
    frame = plan.analysis.frame
    height, res, widen = frame.shape[0], frame.resolution, plan.params.robot_radius
    rows = 0.0
    for obstacle in given:
        if type(obstacle) is not list:
            rows += min(height, 2.0 * (obstacle.radius + widen) / res + 1.0)
    return rows


def _obstacle_cells(plan: planner.Plan, given: list[Any]) -> Obstacles:
    """The cells the step's obstacles block: cells as given, circles as the cells whose
    centers are within ``radius + robot_radius`` of theirs (then an ``(n, 2)`` array: a
    circle over a whole map is a million cells, too many to hold as Python lists)."""
    cells: list[list[int]] = []
    circles = []
    for obstacle in given:
        if type(obstacle) is list:
            cells.append(obstacle)
        else:
            circles.append(obstacle.model_dump())
    if not circles:
        return cells  # as given: the planner checks them, and quotes one out of the map
    covered = planner.circle_cells(
        frame_map(plan.analysis.frame), circles, robot_radius=plan.params.robot_radius
    )
    return np.concatenate([np.array(cells, dtype=np.int64).reshape(-1, 2), covered])


async def render_plan(
    engine: Engine,
    plan_id: str,
    field: planner.render.Field | None,
    cell: int | None,
    crop: bool = True,
) -> bytes:
    record = await _record(engine, plan_id)
    plan = await engine.plan_of(record)
    trajectory = await engine.store.get_trajectory(plan_id)
    size = cell_size(plan.analysis.shape, cell)
    crossed = await passages.crossed(engine, record, plan)
    return await engine.pool.run(
        planner.render_plan, plan, trajectory=trajectory, field=field, cell=size,
        passages=crossed, crop=crop,
    )  # fmt: skip


async def plan_path(engine: Engine, plan_id: str) -> planner.Plan:
    """The stored plan with its poses computed (in the pool, if not yet)."""
    return await engine.plan_of(await _record(engine, plan_id), preview=True)


async def require(engine: Engine, plan_id: str) -> None:
    """``NotFound`` unless the plan exists now."""
    await _record(engine, plan_id)


async def _record(engine: Engine, plan_id: str) -> PlanRecord:
    """The plan's record; ``NotFound`` naming the plan when it is gone, naming its map when
    the map is (then the plan cannot be drawn or stepped on any replica: see ``step``)."""
    record = await engine.store.get_plan(plan_id)
    if record is None:
        raise _unknown_plan(plan_id)
    if "map_id" in record and not await engine.store.has_map(record["map_id"]):
        raise unknown_map(record["map_id"])
    return record


def _unknown_plan(plan_id: str) -> NotFound:
    msg = f"plan_id: no plan {quote(plan_id)} (unknown, deleted or expired)"
    return NotFound(msg, field="plan_id")

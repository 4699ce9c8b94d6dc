"""``/plan``: create, read, delete a plan, and step the robot along it."""

from __future__ import annotations

import time
from typing import Annotated, Any, Literal

import orjson
from fastapi import APIRouter, FastAPI, Query, Response, status
from fastapi.routing import APIRoute

from schemas import (
    FRAME_ID_MAX,
    FRAME_ID_PATTERN,
    NavPath,
    PlanCreate,
    PlanDetail,
    PlanGoalUpdate,
    PlanPublic,
    StepCreate,
    StepPublic,
)
from service.api import present
from service.api.deps import PNG_ROUTE, CellQuery, CropQuery, EngineDep, OrjsonRoute, StepBody
from service.errors import responses
from service.resources import plans
from service.viewer.events import BusDep, EventBus, channel
from service.work.engine import Engine

__all__ = ["add_step_route", "router"]

router = APIRouter(tags=["plans"], route_class=OrjsonRoute)

STEP_BODY = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {"schema": {"$ref": "#/components/schemas/StepCreate"}}},
    }
}
"""The step's body in ``/docs``: its dependency reads it (:data:`StepBody`)."""


async def step(plan_id: str, body: StepBody, engine: EngineDep, bus: BusDep) -> Response:
    """Give the dynamic obstacles now, as cells and circles `{x, y, radius}` in meters (and
    optionally where the robot really is, a cell or a point `{x, y, yaw?}`); the answer is the
    cell to move to (and its center `position_xy`), which the service records, and the path
    ahead as `poses` `{x, y, yaw}` (at least `horizon_m` meters, clear of this step's
    obstacles) with `remaining_m`. `seq`, when given, must be
    the last step's `seq` + 1; the last `seq` again returns the same answer without moving the
    robot (a safe retry); anything else is `409`. Steps on one plan are served one at a time."""
    # Built and encoded directly: `response_model` documents it, and
    # tests/service/test_api.py checks that its answers validate as StepPublic.
    answer = await _stepped(engine, bus, plan_id, body)
    return Response(orjson.dumps(answer), media_type="application/json")


async def _stepped(engine: Engine, bus: EventBus, plan_id: str, body: StepCreate) -> dict[str, Any]:
    """The step's answer, its event published for the live viewer: with the step's write when
    the store reaches the bus (a step decided again, when another replica wrote first, makes
    its event again), else after it, when anyone listens."""
    made: list[tuple[plans.StepView, dict[str, Any]]] = []  # the answer, built once

    def event(view: plans.StepView) -> tuple[str, bytes]:
        made.append((view, present.step_answer(view)))
        return channel(plan_id), orjson.dumps(_event(made[-1][1], view))

    if bus.in_store and engine.store.publishes:
        view = await plans.step(engine, plan_id, body, event=event)
        return made[-1][1] if made and made[-1][0] is view else present.step_answer(view)
    view = await plans.step(engine, plan_id, body)
    answer = present.step_answer(view)
    if not view.replayed and bus.listening(plan_id):  # a retry is not a new step
        await bus.publish(plan_id, orjson.dumps(_event(answer, view)))
    return answer


def add_step_route(app: FastAPI) -> APIRoute:
    """Add the step to the app's own routes, and return its route.

    A step is the hot request. FastAPI matches the routes of an included router (``router``)
    through a layer of its own on every request; a route of the app is matched directly. It is a
    plain ``APIRoute``: its body's dependency reads and checks it (``StepBody``), so
    ``OrjsonRoute``'s second ``Request`` and second look at the body would be work done
    twice."""
    app.add_api_route(
        "/plan/{plan_id}/step",
        step,
        methods=["POST"],
        tags=["plans"],
        response_model=StepPublic,
        summary="Report the dynamic obstacles; get the move to make now",
        responses=responses(404, 409, 413, 422),
        openapi_extra=STEP_BODY,
    )
    route = app.router.routes[-1]
    assert isinstance(route, APIRoute)
    return route


def _event(answer: dict[str, Any], view: plans.StepView) -> dict[str, Any]:
    """What the live viewer gets of a step: its answer, and the cells the obstacles blocked
    (it draws cells: circles go out as the cells they blocked)."""
    cells = view.obstacles
    return {**answer, "dynamic_obstacles": cells if isinstance(cells, list) else cells.tolist()}


@router.post(
    "/plan",
    status_code=status.HTTP_201_CREATED,
    summary="Plan from start to goal on an uploaded map",
    responses=responses(404, 413, 422, 429),
)
async def create_plan(body: PlanCreate, engine: EngineDep) -> PlanPublic:
    """Analyse the map (cached per map and analysis parameters), run the goal wave (cached per
    goal) and return the plan with its `preview`: the path with no dynamic obstacles. `422`
    when start or goal is outside the map or blocked, or with `NO_VALID_PATH` when the goal
    cannot be reached (or only through tight tunnels while `allow_narrow` is false); `404`
    when the map is not in the store (whatever a replica has cached); `429` `TOO_MANY_PLANS`
    when the key holds `PLANNER_MAX_PLANS_PER_TENANT` live plans."""
    return present.plan_public(await plans.create_plan(engine, body))


@router.get(
    "/plan/{plan_id}", summary="A plan and the robot's progress", responses=responses(404, 422)
)
async def get_plan(plan_id: str, engine: EngineDep) -> PlanDetail:
    """The plan as created, with the robot's `position`, `status`, `iteration`, `trajectory`
    and the trajectory's metrics."""
    return present.plan_detail(await plans.get_plan(engine, plan_id))


@router.get(
    "/plan/{plan_id}/path",
    response_model=NavPath,
    summary="The plan's poses as a nav_msgs/Path",
    responses=responses(404, 422),
)
async def get_path(
    plan_id: str,
    engine: EngineDep,
    frame_id: Annotated[
        str,
        Query(
            min_length=1,
            max_length=FRAME_ID_MAX,
            pattern=FRAME_ID_PATTERN,
            description="The header's `frame_id`: letters, digits, `_ . / -` (default `map`).",
        ),
    ] = "map",
) -> Response:
    """The `preview.poses` as a rosbridge-style `nav_msgs/Path`: a header (`frame_id`, `stamp`
    now) and, per pose, a `geometry_msgs/PoseStamped` whose position is `(x, y, 0)` and whose
    orientation is the yaw's quaternion `(0, 0, sin(yaw/2), cos(yaw/2))`."""
    plan = await plans.plan_path(engine, plan_id)
    answer = present.nav_path(plan, frame_id, time.time())
    # Built and encoded directly (thousands of poses): `response_model` documents it, and
    # tests/service/test_poses.py checks that its answers validate as NavPath.
    return Response(orjson.dumps(answer), media_type="application/json")


@router.patch(
    "/plan/{plan_id}",
    summary="Give a fleet robot a new goal",
    responses=responses(404, 422),
)
async def change_goal(plan_id: str, body: PlanGoalUpdate, engine: EngineDep) -> PlanDetail:
    """A fleet robot's new `goal` (a cell, or a point in meters): its fleet is solved again at
    its next step, from where its robots are. `422` `FLEET_GOAL_TAKEN` when the goal is within
    both radii of another robot's goal; `422` for a plan in no fleet (plan it again instead)."""
    return present.plan_detail(await plans.change_goal(engine, plan_id, body.goal))


@router.delete(
    "/plan/{plan_id}",
    status_code=status.HTTP_204_NO_CONTENT,
    summary="Forget a plan",
    responses=responses(404, 422),
)
async def delete_plan(plan_id: str, engine: EngineDep) -> None:
    """Forget the plan now (plans also expire when untouched for `PLANNER_PLAN_TTL_SECONDS`)."""
    await plans.delete_plan(engine, plan_id)


@router.get(
    "/plan/{plan_id}/render.png",
    summary="A picture of the plan and the robot's progress",
    **PNG_ROUTE,
)
async def render_plan(
    plan_id: str,
    engine: EngineDep,
    field: Annotated[
        Literal["clean", "kw"] | None,
        Query(description="Tint free cells by their clean penalty or wide cost-to-go `kw`."),
    ] = None,
    cell: CellQuery = None,
    crop: CropQuery = True,
) -> Response:
    """The plan's map with its analysis, the `preview` path (pale green), the robot's
    trajectory so far (green) and its cell, the start (magenta) and the goal (gold), and the
    `preview.poses` the robot drives (a blue line, the goal's heading an arrow), and the narrow
    passages it crosses (`preview.passages`: violet, labelled with their id and width). The
    picture holds the known part of the map (`crop=false`: all of it)."""
    png = await plans.render_plan(engine, plan_id, field, cell, crop)
    return Response(png, media_type="image/png")

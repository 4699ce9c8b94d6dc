"""``/plan/{plan_id}/view``: a live page of the robot on its map; ``/plan/{plan_id}/events``: the
plan's steps as server-sent events, which feed it."""

from __future__ import annotations

import html
from collections.abc import AsyncIterator
from importlib import resources
from typing import Any

import orjson
from fastapi import APIRouter
from fastapi.responses import HTMLResponse, StreamingResponse
from starlette.background import BackgroundTask

import planner
from planner.motion.robots import robot_of
from schemas import ErrorPublic
from service.api.deps import EngineDep
from service.errors import responses
from service.resources import plans
from service.viewer.events import DROPPED, BusDep, Dropped, Subscription

__all__ = ["router"]

router = APIRouter(tags=["plans"])

PAGE = (resources.files("service.viewer") / "viewer.html").read_text(encoding="utf-8")


@router.get(
    "/plan/{plan_id}/view",
    summary="A live page of the robot on its map",
    response_class=HTMLResponse,
    responses={200: {"content": {"text/html": {}}}, **responses(404, 422)},
)
async def view(plan_id: str, engine: EngineDep) -> HTMLResponse:
    """An HTML page drawing the plan's map, its planned path, the robot (`#robot`, its cell in
    `data-cell`), the dynamic obstacles of the latest step (`.dynamic-obstacle`), its path
    ahead (`#ahead`, a polyline through its poses) and heading (`#heading`, the first pose's
    yaw in `data-yaw`), a robot with a footprint or a car motion outlined along its path ahead
    every 0.3 m (`.outline`; the picture beneath outlines it along the plan's poses), and on a
    zoned map its zones (`.keepout` polygons hatched red,
    `.speed-zone` polygons labelled by `.speed-label` with their max speed), updated
    live from `/plan/{plan_id}/events` as steps arrive; on a robot map, the map's narrow
    passages for the plan's robot (`.passage`, from `/maps/{map_id}/passages`: a dot and its
    width in meters) and the map's live marks (`.live-mark`, from `/maps/{map_id}/live`, read
    each second). Everything it loads comes from the service."""
    view_ = await plans.get_plan(engine, plan_id)
    height, width = view_.plan.analysis.shape
    robot = robot_of(view_.plan.params, view_.plan.analysis.frame.resolution)
    zones = view_.plan.analysis.zones
    passages = live = None
    if not view_.plan.analysis.plain:  # relative to the page: /maps/{map_id}/passages
        radius = view_.plan.params.robot_radius
        passages = f"../../maps/{view_.record['map_id']}/passages?robot_radius={radius!r}"
        live = f"../../maps/{view_.record['map_id']}/live"
    data = {
        "plan_id": plan_id,
        "name": view_.record.get("name"),
        "height": height,
        "width": width,
        "cell": max(1, min(32, 800 // max(height, width))),
        "position": list(view_.state.position),
        "trajectory": [list(cell) for cell in view_.state.trajectory],
        "resolution": view_.plan.analysis.frame.resolution,
        "origin": list(view_.plan.analysis.frame.origin),
        "last_step": _last_step(view_.state.last_step),
        "zones": None if zones is None else zones.as_dict(),
        "passages_url": passages,
        "live_url": live,
        "footprint": None if robot is None else [list(v) for v in robot.footprint.vertices],
    }
    # Inside <script>: "</" must not close it.
    embedded = orjson.dumps(data).decode().replace("</", "<\\/")
    page = PAGE.replace("__PLAN_ID__", html.escape(plan_id))
    return HTMLResponse(page.replace("__PLAN_DATA__", embedded))


def _last_step(step: planner.Step | None) -> dict[str, Any] | None:
    """What the page's status line says of the latest step (``None``: no step yet)."""
    if step is None:
        return None
    keys = ("seq", "move", "position", "status", "remaining_m")
    return {key: value for key, value in step.as_dict().items() if key in keys}


@router.get(
    "/plan/{plan_id}/events",
    summary="The plan's steps as server-sent events",
    response_class=StreamingResponse,
    responses={200: {"content": {"text/event-stream": {}}}, **responses(404, 422, 503)},
)
async def events(plan_id: str, engine: EngineDep, bus: BusDep) -> StreamingResponse:
    """`text/event-stream`: one event per step served from now on, by any replica; its `data`
    is the step's answer with the step's `dynamic_obstacles` (`seq`, `position`, `move`,
    `status`, ...). A comment every 15 s keeps idle connections open. A reader more than
    `PLANNER_STREAM_QUEUE_BYTES` behind gets a last event, `event: dropped` (its `data` an
    error, code `TOO_SLOW`), and the stream ends; a key may hold
    `PLANNER_MAX_STREAMS_PER_TENANT` streams on a replica (`503` `TOO_MANY_STREAMS` beyond)."""
    await plans.require(engine, plan_id)
    subscription = await bus.subscribe(plan_id)
    headers = {"Cache-Control": "no-cache", "X-Accel-Buffering": "no"}  # nginx: no buffering
    return StreamingResponse(
        _frames(subscription),
        media_type="text/event-stream",
        headers=headers,
        background=BackgroundTask(subscription.close),
    )


_DROPPED = orjson.dumps(
    ErrorPublic(
        detail="this stream fell more than PLANNER_STREAM_QUEUE_BYTES of events behind its "
        "steps and was dropped; read faster, or reconnect to follow from now on",
        field=None,
        code=DROPPED,
    ).model_dump()
)
"""The ``data`` of the ``dropped`` event."""


async def _frames(subscription: Subscription) -> AsyncIterator[bytes]:
    try:
        yield b": subscribed\n\n"
        while True:
            try:
                event = await subscription.next()
            except EOFError:  # the bus is gone: the browser reconnects by itself
                return
            except Dropped:
                yield b"event: dropped\ndata: " + _DROPPED + b"\n\n"
                return
            yield b": keep-alive\n\n" if event is None else b"data: " + event + b"\n\n"
    finally:
        await subscription.close()

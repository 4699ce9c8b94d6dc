"""The edge (``service.edge.middleware.Edge``) and the step route: a step is a plain FastAPI
route whose body it reads with ``StepCreate.model_validate_json``, answering what FastAPI answers
for a body parameter of that model (statuses, bodies, headers, the errors mapped by the app's
handlers), and the edge refuses, bounds, times and labels it (401, 413, 408, 504, request ids,
metric labels, 500 for an unmapped error). ``test_bad_input.py`` and ``test_hardening.py`` pin
the rest."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest
from fastapi import APIRouter, FastAPI, Response
from fastapi.routing import APIRoute
from pydantic import SecretStr

from schemas import StepCreate
from service.api.deps import EngineDep, OrjsonRoute
from service.api.routes import plans
from service.main import create_app
from service.viewer.events import BusDep
from service.work.engine import Engine
from tests.service.conftest import SMALL, running

pytestmark = pytest.mark.anyio

JSON = {"content-type": "application/json"}

ROWS = [".........", ".........", "..@@@@@..", ".........", "........."]

# (headers, body) of steps on a plan: the good, then every way of getting one wrong.
STEPS: list[tuple[dict[str, str], bytes]] = [
    ({"content-type": "application/json"}, b'{"seq": 0, "dynamic_obstacles": [[1, 1]]}'),
    ({"content-type": "application/json"}, b'{"seq": 0, "dynamic_obstacles": [[1, 1]]}'),
    ({"content-type": "application/json"}, b'{"seq": 1, "dynamic_obstacles": [[0, 5], [3, 3]]}'),
    ({"content-type": "application/json"}, b'{"seq": 7}'),
    ({"content-type": "application/json"}, b'{"seq": 2, "obstacles": []}'),
    ({"content-type": "application/json"}, b'{"seq": "2"}'),
    ({"content-type": "application/json"}, b'{"seq": 2, "dynamic_obstacles": [[true, 0]]}'),
    ({"content-type": "application/json"}, b'{"seq": 2, "position": [1, 2]}'),
    ({"content-type": "application/json"}, b'{"seq": 2, "position": {"x": 1}}'),
    ({"content-type": "application/json"}, b'{"seq": 2,'),
    ({"content-type": "application/json"}, b""),
    ({"content-type": "application/json"}, b"[]"),
    ({"content-type": "application/json"}, b'{"x": ' + b"[" * 70 + b"]" * 70 + b"}"),
    ({"content-type": "text/plain"}, b'{"seq": 2}'),
    ({}, b'{"seq": 2}'),
    ({"content-type": "application/vnd.api+json"}, b'{"seq": 2, "dynamic_obstacles": []}'),
]


def _with_a_body_parameter(app: FastAPI) -> FastAPI:
    """The app, its step served first by a route that takes the body as FastAPI's own body
    parameter (FastAPI reads and validates it), then hands the request to the real step."""

    async def step(plan_id: str, body: StepCreate, engine: EngineDep, bus: BusDep) -> Response:
        return await plans.step(plan_id, body, engine, bus)

    reference = APIRouter(route_class=OrjsonRoute)
    reference.add_api_route("/plan/{plan_id}/step", step, methods=["POST"])
    app.include_router(reference)
    app.router.routes.insert(0, app.router.routes.pop())
    return app


async def _answers(app: FastAPI) -> list[tuple[int, Any, str | None]]:
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
            body = {"map_id": map_id, "start": [0, 0], "goal": [4, 8], "preset": "wide"}
            plan_id = (await client.post("/plan", json=body)).json()["plan_id"]
            out = []
            for headers, content in STEPS:
                r = await client.post(f"/plan/{plan_id}/step", content=content, headers=headers)
                out.append((r.status_code, r.json(), r.headers.get("content-type")))
            for method in ("GET", "PUT"):  # not a step: on to the router, as before
                r = await client.request(method, f"/plan/{plan_id}/step")
                out.append((r.status_code, r.json(), r.headers.get("content-type")))
            r = await client.post("/plan/nope/step", json={"seq": 0})
            out.append((r.status_code, r.json(), r.headers.get("content-type")))
            metrics = (await client.get("/metrics")).text
    # Served by either road, a step is counted under its route template.
    assert 'route="/plan/{plan_id}/step",status="200"' in metrics
    return out


async def test_the_step_answers_what_a_body_parameter_answers() -> None:
    ours = await _answers(create_app(SMALL))
    reference = await _answers(_with_a_body_parameter(create_app(SMALL)))
    assert [a[0] for a in ours] == [200, 200, 200, 409, 422, 422, 422, 200, 422, 422, 422,
                                    422, 422, 422, 422, 200, 405, 405, 404]  # fmt: skip
    # pydantic's JSON mode words one error its own way: a body that is JSON but no object.
    words = "Input should be a valid dictionary or object to extract fields from"
    assert ours[11][1]["detail"] == "body: Input should be an object; got []"
    ours[11][1]["detail"] = f"body: {words}; got []"
    assert ours == reference


async def _guarded_answers(
    app: FastAPI,
) -> tuple[list[tuple[int, Any, str | None, str | None]], str]:
    """Steps refused before their body is read (no key, a wrong key, too long by
    Content-Length) or while it is (too long as it streams), served with the plan's key, and
    unknown with another."""
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            keyed = {"X-API-Key": "k1"}
            map_id = (await client.post("/maps", json={"rows": ROWS}, headers=keyed)).json()
            body = {"map_id": map_id["map_id"], "start": [0, 0], "goal": [4, 8]}
            plan_id = (await client.post("/plan", json=body, headers=keyed)).json()["plan_id"]
            url = f"/plan/{plan_id}/step"
            big = b'{"seq": 0, "dynamic_obstacles": [' + b"[1, 1], " * 40 + b"[1, 1]]}"

            async def streamed() -> AsyncIterator[bytes]:
                yield big[:100]
                yield big[100:]

            tries: list[tuple[dict[str, str], Any]] = [
                ({}, b'{"seq": 0}'),
                ({"Authorization": "Bearer nope"}, b'{"seq": 0}'),
                ({**keyed, "X-Request-ID": "trace-7"}, big),
                ({**keyed, "X-Request-ID": "trace-8"}, streamed()),
                ({"Authorization": "Bearer k1", "X-Request-ID": "trace-9"}, b'{"seq": 0}'),
                ({"Authorization": "Bearer k2"}, b'{"seq": 1}'),  # another tenant's plan
            ]
            out = []
            for headers, content in tries:
                headers = {"content-type": "application/json", **headers}
                r = await client.post(url, content=content, headers=headers)
                answer = json.loads(r.text.replace(plan_id, "P"))  # ids differ run to run
                out.append(
                    (r.status_code, answer, r.headers.get("www-authenticate"),
                     r.headers.get("x-request-id") if "X-Request-ID" in headers else None)
                )  # fmt: skip
            metrics = (await client.get("/metrics")).text
    return out, metrics


async def test_the_edge_guards_a_step() -> None:
    """API keys, body limits (by Content-Length and as the body streams in) and request ids."""
    settings = SMALL.model_copy(update={"api_keys": SecretStr("k1,k2"), "max_step_body_bytes": 200})
    answers, metrics = await _guarded_answers(create_app(settings))
    assert [a[0] for a in answers] == [401, 401, 413, 413, 200, 404]
    assert [a[1].get("code") for a in answers] == [
        "UNAUTHORIZED", "UNAUTHORIZED", "TOO_LARGE", "TOO_LARGE", None, "NOT_FOUND"
    ]  # fmt: skip
    assert [a[2] for a in answers] == ['Bearer realm="planner"'] * 2 + [None] * 4
    assert [a[3] for a in answers] == [None, None, "trace-7", "trace-8", "trace-9", None]
    assert "PLANNER_MAX_STEP_BODY_BYTES is 200" in answers[2][1]["detail"]
    assert answers[4][1]["seq"] == 0
    # Counted under the step's route, its refusals too (the edge labels a request it refused
    # before routing with the route the router would have given it).
    for status in (401, 413, 200, 404):
        assert f'route="/plan/{{plan_id}}/step",status="{status}"' in metrics


async def test_the_step_is_a_plain_fastapi_route() -> None:
    """Served by an ``APIRoute`` of the app's own router (no road around it), behind the one
    edge middleware, in an app that is FastAPI itself."""
    app = create_app(SMALL)
    assert type(app) is FastAPI
    assert [m.cls.__name__ for m in app.user_middleware] == ["Edge"]  # type: ignore[attr-defined]
    route = next(r for r in app.router.routes if getattr(r, "path", None) == "/plan/{plan_id}/step")
    assert isinstance(route, APIRoute)
    assert not any(getattr(r, "path", None) == route.path for r in plans.router.routes)
    assert route.endpoint is plans.step
    assert route.methods == {"POST"}
    served: list[Any] = []

    async def probe(scope: Any, receive: Any, send: Any) -> None:
        await app(scope, receive, send)
        served.append(scope.get("route"))  # as the router left it

    async with running(app):
        transport = httpx.ASGITransport(app=probe)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
            body = {"map_id": map_id, "start": [0, 0], "goal": [4, 8]}
            plan_id = (await client.post("/plan", json=body)).json()["plan_id"]
            r = await client.post(f"/plan/{plan_id}/step", json={"seq": 0})
            assert r.status_code == 200
    assert served[-1] is route


TIMEOUT = 1.0
"""Seconds the edge gives a body and a request in these tests: the map's upload and the plan
before the stalls must fit in it on a loaded machine (0.2 s did not, once in CI)."""
STALL = 3 * TIMEOUT
"""How long a body stalls, or a step runs, past the timeout."""


async def _timed_answers(
    app: FastAPI, monkeypatch: pytest.MonkeyPatch
) -> list[tuple[int, Any, str | None]]:
    """A body that stalls (408, the connection closed) and a step that runs long (504)."""
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
            body = {"map_id": map_id, "start": [0, 0], "goal": [4, 8]}
            plan_id = (await client.post("/plan", json=body)).json()["plan_id"]
            url = f"/plan/{plan_id}/step"

            async def stalling() -> AsyncIterator[bytes]:
                yield b'{"seq": '
                await asyncio.sleep(STALL)
                yield b"0}"

            out = []
            r = await client.post(url, content=stalling(), headers=JSON)
            out.append((r.status_code, r.json()["code"], r.headers.get("connection")))

            async def slow(*args: Any, **kwargs: Any) -> Any:
                await asyncio.sleep(STALL)

            with monkeypatch.context() as patched:
                patched.setattr(Engine, "step", slow)
                r = await client.post(url, json={"seq": 0})
            out.append((r.status_code, r.json()["code"], r.headers.get("connection")))
            r = await client.post(url, json={"seq": 0})  # the stopped step moved nothing
            out.append((r.status_code, r.json()["seq"], None))
    return out


async def test_the_edge_times_a_step(monkeypatch: pytest.MonkeyPatch) -> None:
    settings = SMALL.model_copy(
        update={"body_timeout_seconds": TIMEOUT, "request_timeout_seconds": TIMEOUT}
    )
    answers = await _timed_answers(create_app(settings), monkeypatch)
    assert answers == [(408, "BODY_TIMEOUT", "close"), (504, "TIMED_OUT", None), (200, 0, None)]


async def test_an_unexpected_error_in_a_step_is_a_500_counted_under_its_route(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """An error no handler maps: the server answers 500 (the app sent nothing) and the step
    is counted and logged as a 500."""

    async def broken(*args: Any, **kwargs: Any) -> Any:
        raise RuntimeError("a bug")

    for app in (create_app(SMALL),):
        async with running(app):
            transport = httpx.ASGITransport(app=app, raise_app_exceptions=False)
            async with httpx.AsyncClient(transport=transport, base_url="http://s") as client:
                map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
                body = {"map_id": map_id, "start": [0, 0], "goal": [4, 8]}
                plan_id = (await client.post("/plan", json=body)).json()["plan_id"]
                with monkeypatch.context() as patched:
                    patched.setattr(Engine, "step", broken)
                    r = await client.post(f"/plan/{plan_id}/step", json={"seq": 0})
                assert r.status_code == 500
                metrics = (await client.get("/metrics")).text
                assert 'route="/plan/{plan_id}/step",status="500"' in metrics
                r = await client.post(f"/plan/{plan_id}/step", json={"seq": 0})
                assert r.status_code == 200  # nothing was recorded: seq 0 is still next

"""The hot path (``service.api.hot``): a step served by ``HotPath`` answers exactly what the
router answers with the same route (statuses, bodies, headers, the errors mapped by the app's
handlers, the metrics' route label), for good and bad requests alike. The route's own body
handling keeps FastAPI's answers: ``test_bad_input.py`` and ``test_hardening.py`` pin them."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from pydantic import SecretStr

from service.api.hot import HotPath
from service.main import create_app
from service.work.engine import Engine
from tests.service.conftest import SMALL

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


def _without_hot_path(app: FastAPI) -> FastAPI:
    app.user_middleware = [
        m for m in app.user_middleware if getattr(m.cls, "__name__", None) != HotPath.__name__
    ]
    return app


async def _answers(app: FastAPI) -> list[tuple[int, Any, str | None]]:
    async with app.router.lifespan_context(app):
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


async def test_the_hot_path_answers_what_the_router_answers() -> None:
    hot = await _answers(create_app(SMALL))
    routed = await _answers(_without_hot_path(create_app(SMALL)))
    assert [a[0] for a in hot] == [200, 200, 200, 409, 422, 422, 422, 200, 422, 422, 422,
                                   422, 422, 422, 422, 200, 405, 405, 404]  # fmt: skip
    assert hot == routed


async def _guarded_answers(
    app: FastAPI,
) -> tuple[list[tuple[int, Any, str | None, str | None]], str]:
    """Steps refused before their body is read (no key, a wrong key, too long by
    Content-Length) or while it is (too long as it streams), served with the plan's key, and
    unknown with another."""
    async with app.router.lifespan_context(app):
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


async def test_the_hot_path_guards_a_step_as_the_middlewares_do() -> None:
    """API keys, body limits and request ids: the hot path's answers are the middlewares'."""
    settings = SMALL.model_copy(update={"api_keys": SecretStr("k1,k2"), "max_step_body_bytes": 200})
    hot, metrics = await _guarded_answers(create_app(settings))
    routed, _ = await _guarded_answers(_without_hot_path(create_app(settings)))
    assert [a[0] for a in hot] == [401, 401, 413, 413, 200, 404]
    assert [a[3] for a in hot] == [None, None, "trace-7", "trace-8", "trace-9", None]
    assert hot == routed
    # Counted under the step's route, its refusals too (the middlewares, before any route
    # matched, count theirs as "unmatched").
    for status in (401, 413, 200, 404):
        assert f'route="/plan/{{plan_id}}/step",status="{status}"' in metrics


def test_the_app_serves_steps_by_the_hot_path() -> None:
    assert any(
        getattr(m.cls, "__name__", None) == HotPath.__name__
        for m in create_app(SMALL).user_middleware
    )


async def _timed_answers(
    app: FastAPI, monkeypatch: pytest.MonkeyPatch
) -> list[tuple[int, Any, str | None]]:
    """A body that stalls (408, the connection closed) and a step that runs long (504)."""
    async with app.router.lifespan_context(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
            body = {"map_id": map_id, "start": [0, 0], "goal": [4, 8]}
            plan_id = (await client.post("/plan", json=body)).json()["plan_id"]
            url = f"/plan/{plan_id}/step"

            async def stalling() -> AsyncIterator[bytes]:
                yield b'{"seq": '
                await asyncio.sleep(1)
                yield b"0}"

            out = []
            r = await client.post(url, content=stalling(), headers=JSON)
            out.append((r.status_code, r.json()["code"], r.headers.get("connection")))

            async def slow(*args: Any, **kwargs: Any) -> Any:
                await asyncio.sleep(1)

            with monkeypatch.context() as patched:
                patched.setattr(Engine, "step", slow)
                r = await client.post(url, json={"seq": 0})
            out.append((r.status_code, r.json()["code"], r.headers.get("connection")))
            r = await client.post(url, json={"seq": 0})  # the stopped step moved nothing
            out.append((r.status_code, r.json()["seq"], None))
    return out


async def test_the_hot_path_times_a_step_as_the_middlewares_do(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    settings = SMALL.model_copy(
        update={"body_timeout_seconds": 0.2, "request_timeout_seconds": 0.2}
    )
    hot = await _timed_answers(create_app(settings), monkeypatch)
    routed = await _timed_answers(_without_hot_path(create_app(settings)), monkeypatch)
    assert hot == [(408, "BODY_TIMEOUT", "close"), (504, "TIMED_OUT", None), (200, 0, None)]
    assert hot == routed


async def test_an_unexpected_error_in_a_step_is_a_500_counted_under_its_route(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """An error no handler maps: the server answers 500 (the app sent nothing) and the step
    is counted and logged as a 500, whichever road served it."""

    async def broken(*args: Any, **kwargs: Any) -> Any:
        raise RuntimeError("a bug")

    for app in (create_app(SMALL), _without_hot_path(create_app(SMALL))):
        async with app.router.lifespan_context(app):
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

"""The hot path (``service.api.hot``): a step served by ``HotPath`` answers exactly what the
router answers with the same route (statuses, bodies, headers, the errors mapped by the app's
handlers, the metrics' route label), for good and bad requests alike. The route's own body
handling keeps FastAPI's answers: ``test_bad_input.py`` and ``test_hardening.py`` pin them."""

from __future__ import annotations

from typing import Any

import httpx
import pytest
from fastapi import FastAPI

from service.api.hot import HotPath
from service.main import create_app
from tests.service.conftest import SMALL

pytestmark = pytest.mark.anyio

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


def test_the_app_serves_steps_by_the_hot_path() -> None:
    assert any(
        getattr(m.cls, "__name__", None) == HotPath.__name__
        for m in create_app(SMALL).user_middleware
    )

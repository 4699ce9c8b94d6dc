"""``GET /maps/{map_id}/passages`` and a plan's ``narrowest`` and ``passages``: the doors of a
built map over ASGI (cached, tenant-scoped, bad parameters named), the shared depot map and
the Python client through a real uvicorn."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from pydantic import SecretStr

import planner
from service.client import PlannerClient, ValidationError
from service.config import Settings
from service.main import create_app
from tests.doors import ORIGIN, RESOLUTION, doors_grid, doors_map
from tests.service.conftest import running

SETTINGS = Settings(pool_size=2, max_map_cells=100_000)
RADIUS = 0.2


@pytest.fixture
def settings() -> Settings:
    return SETTINGS


async def upload_doors(client: httpx.AsyncClient, **headers: str) -> str:
    grid, _ = doors_grid()
    body = {"grid": grid.tolist(), "resolution": RESOLUTION, "origin": list(ORIGIN)}
    r = await client.post("/maps", json=body, headers=headers)
    assert r.status_code in (200, 201), r.text
    return str(r.json()["map_id"])


def expected(radius: float, max_width: float | None) -> list[dict[str, Any]]:
    return [
        {
            "id": p.id,
            "x": round(p.x, 6),
            "y": round(p.y, 6),
            "width_m": round(p.width_m, 6),
            "length_m": round(p.length_m, 6),
        }
        for p in planner.find_passages(doors_map(), radius, max_width)
    ]


@pytest.mark.anyio
@pytest.mark.parametrize(("max_width", "count"), [(None, 1), (0.9, 2), (1.1, 3), (2.0, 4)])
async def test_the_doors_narrower_than_max_width(
    client: httpx.AsyncClient, max_width: float | None, count: int
) -> None:
    map_id = await upload_doors(client)
    query: dict[str, Any] = {"robot_radius": RADIUS}
    if max_width is not None:
        query["max_width"] = max_width
    r = await client.get(f"/maps/{map_id}/passages", params=query)
    assert r.status_code == 200, r.text
    got = r.json()
    assert got["passages"] == expected(RADIUS, max_width)
    assert len(got["passages"]) == count
    assert got["robot_radius"] == RADIUS
    assert got["max_width"] == pytest.approx(max_width or 2 * RADIUS + 0.3)
    assert got["passages"][0]["width_m"] == pytest.approx(0.6)  # the 0.55 m door


@pytest.mark.anyio
async def test_computed_once_per_map_radius_and_max_width(app: FastAPI) -> None:
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            map_id = await upload_doors(client)
            url = f"/maps/{map_id}/passages"
            cache = app.state.engine.cache
            first = await client.get(url, params={"robot_radius": RADIUS})
            misses = cache.misses
            # The default max_width given explicitly is the same entry.
            again = await client.get(url, params={"robot_radius": RADIUS, "max_width": 0.7})
            assert again.json() == first.json()
            assert cache.misses == misses
            other = await client.get(url, params={"robot_radius": RADIUS, "max_width": 1.1})
            assert len(other.json()["passages"]) == 3
            assert cache.misses == misses + 1


@pytest.mark.anyio
@pytest.mark.parametrize(
    ("query", "field"),
    [
        ("", "robot_radius"),
        ("robot_radius=-0.1", "robot_radius"),
        ("robot_radius=nan", "robot_radius"),
        ("robot_radius=inf", "robot_radius"),
        ("robot_radius=abc", "robot_radius"),
        ("robot_radius=0.2&max_width=0.4", "max_width"),
        ("robot_radius=0.2&max_width=0.1", "max_width"),
        ("robot_radius=0.2&max_width=0", "max_width"),
        ("robot_radius=0.2&max_width=nan", "max_width"),
        ("robot_radius=0.2&max_width=-1", "max_width"),
        ("robot_radius=0.2&max_widht=1", "max_widht"),
    ],
)
async def test_bad_parameters_name_the_field(
    client: httpx.AsyncClient, query: str, field: str
) -> None:
    map_id = await upload_doors(client)
    r = await client.get(f"/maps/{map_id}/passages?{query}")
    assert r.status_code == 422, r.text
    assert r.json()["field"] == field, r.text
    assert r.json()["code"] == "INVALID_INPUT"


@pytest.mark.anyio
async def test_an_unknown_map_is_404(client: httpx.AsyncClient) -> None:
    r = await client.get("/maps/" + "0" * 64 + "/passages", params={"robot_radius": 0.2})
    assert r.status_code == 404, r.text
    assert r.json()["field"] == "map_id"


@pytest.mark.anyio
async def test_another_tenants_map_is_404() -> None:
    app = create_app(SETTINGS.model_copy(update={"api_keys": SecretStr("k1,k2")}))
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            map_id = await upload_doors(client, **{"X-API-Key": "k1"})
            url = f"/maps/{map_id}/passages?robot_radius=0.2"
            mine = await client.get(url, headers={"X-API-Key": "k1"})
            assert mine.status_code == 200, mine.text
            theirs = await client.get(url, headers={"X-API-Key": "k2"})
            assert theirs.status_code == 404, theirs.text
            assert (await client.get(url)).status_code == 401


@pytest.mark.anyio
async def test_a_plan_through_a_door_reports_it(client: httpx.AsyncClient) -> None:
    map_id = await upload_doors(client)
    m = doors_map()
    _, middles = doors_grid()
    row = round(middles[1][0])
    # From the second room to the third, through the 0.55 m door (the only way).
    start, goal = [row, 70], [row, 180]
    body = {"map_id": map_id, "start": start, "goal": goal, "robot_radius": RADIUS}
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    plan = r.json()
    preview = plan["preview"]
    (door,) = planner.find_passages(m, RADIUS)
    assert preview["passages"] == [door.id]
    narrowest = preview["narrowest"]
    assert narrowest["width_m"] == pytest.approx(0.6)
    assert math.dist((narrowest["x"], narrowest["y"]), (door.x, door.y)) <= RESOLUTION * 1.5
    again = (await client.get(f"/plan/{plan['plan_id']}")).json()["preview"]
    assert (again["narrowest"], again["passages"]) == (narrowest, [door.id])
    # Within one room: no passage, the narrowest point beside a wall of it.
    inside = {**body, "goal": [row, 100]}
    preview = (await client.post("/plan", json=inside)).json()["preview"]
    assert preview["passages"] == []
    assert preview["narrowest"]["width_m"] > 0.7


@pytest.mark.anyio
async def test_a_plain_grid_has_no_passages_in_its_preview(client: httpx.AsyncClient) -> None:
    rows = ["......", ".@@@..", "......"]
    r = await client.post("/maps", json={"rows": rows, "start": [0, 0], "goal": [2, 5]})
    assert r.status_code == 201, r.text
    preview = r.json()["plan"]["preview"]
    assert preview["narrowest"] is None
    assert preview["passages"] is None


def test_depot_and_the_client(live_url: str, ros: Path) -> None:
    m = planner.read_ros_map(ros / "depot.yaml")
    with PlannerClient(live_url, timeout=120) as client:
        map_id = client.upload_map(yaml=ros / "depot.yaml").map_id
        got = client.passages(map_id, 0.35, 1.0)
        found = planner.find_passages(m, 0.35, 1.0)
        assert [(p.x, p.y, p.width_m) for p in got.passages] == [
            (round(p.x, 6), round(p.y, 6), round(p.width_m, 6)) for p in found
        ]
        assert got.max_width == 1.0
        assert len(client.passages(map_id, 0.2).passages) == len(planner.find_passages(m, 0.2))
        with pytest.raises(ValidationError) as info:
            client.passages(map_id, 0.5, 0.9)
        assert info.value.field == "max_width"


@pytest.mark.anyio
async def test_pictures_draw_the_passages(client: httpx.AsyncClient) -> None:
    from tests.planner.test_passages import violet

    map_id = await upload_doors(client)
    url = f"/maps/{map_id}/render.png?robot_radius=0.2&cell=2"
    plain = await client.get(url)
    drawn = await client.get(url + "&passages=true")
    assert plain.status_code == drawn.status_code == 200, drawn.text
    assert not violet(plain.content).any()
    (door,) = planner.find_passages(doors_map(), RADIUS)
    assert violet(drawn.content)[door.row * 2, door.col * 2]
    bad = await client.get(url + "&passages=maybe")
    assert bad.status_code == 422
    assert bad.json()["field"] == "passages"
    _, middles = doors_grid()
    row = round(middles[1][0])
    body = {"map_id": map_id, "start": [row, 70], "goal": [row, 180], "robot_radius": RADIUS}
    plan_id = (await client.post("/plan", json=body)).json()["plan_id"]
    picture = await client.get(f"/plan/{plan_id}/render.png?cell=2")
    assert picture.status_code == 200
    assert violet(picture.content)[door.row * 2, door.col * 2]


def test_the_live_viewer_draws_the_passages_in_chromium(live_url: str) -> None:
    from playwright.sync_api import sync_playwright

    from tests.service.browser import FLAGS, chromium

    grid, middles = doors_grid()
    row = round(middles[1][0])
    body = {
        "grid": grid.tolist(), "resolution": RESOLUTION, "origin": list(ORIGIN),
        "start": [row, 70], "goal": [row, 180], "robot_radius": RADIUS,
    }  # fmt: skip
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as http:
        r = http.post("/maps", json=body)
        assert r.status_code in (200, 201), r.text
        plan_id = r.json()["plan"]["plan_id"]
        want = http.get(f"/maps/{r.json()['map_id']}/passages?robot_radius={RADIUS}").json()
        plain = http.post("/maps", json={"rows": ["....", ".@..", "...."], "start": [0, 0],
                                          "goal": [2, 3]}).json()["plan"]["plan_id"]  # fmt: skip
    assert len(want["passages"]) == 1
    outside: list[str] = []
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium(), args=FLAGS)
        try:
            page = browser.new_page(viewport={"width": 900, "height": 400})

            def only_the_service(route: Any) -> None:
                if route.request.url.startswith(f"{live_url}/"):
                    route.continue_()
                else:
                    outside.append(route.request.url)
                    route.abort()

            page.route("**/*", only_the_service)
            page.goto(f"{live_url}/plan/{plan_id}/view")
            page.wait_for_function("document.body.dataset.passages === '1'", timeout=10_000)
            marks = page.locator(".passage")
            assert marks.count() == 1
            (passage,) = want["passages"]
            assert marks.first.get_attribute("data-width") == str(passage["width_m"])
            assert marks.first.locator("text").text_content() == f"{passage['width_m']:.2f} m"
            # Drawn at the passage's point: its cell's center in the board's pixels.
            m = doors_map()
            (r0, c0), *_ = m.frame.cells([[passage["x"], passage["y"]]]).tolist()
            cell = max(1, min(32, 800 // max(m.shape)))
            dot = marks.first.locator("circle")
            assert float(dot.get_attribute("cx") or "nan") == pytest.approx((c0 + 0.5) * cell)
            assert float(dot.get_attribute("cy") or "nan") == pytest.approx((r0 + 0.5) * cell)
            # A plain grid has no meters: no passages asked for, none drawn.
            page.goto(f"{live_url}/plan/{plain}/view")
            page.wait_for_function("document.body.dataset.live === 'true'", timeout=10_000)
            page.wait_for_timeout(300)
            assert page.locator(".passage").count() == 0
        finally:
            browser.close()
    assert outside == []


@pytest.mark.anyio
async def test_passages_on_a_map_beyond_the_bound_are_413_and_plans_still_work(
    client: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Finding passages takes seconds and hundreds of megabytes on a 4096 x 4096 map: beyond
    MAX_PASSAGE_CELLS (here lowered to below the doors map) they are refused, naming the map;
    a plan on such a map is made without them."""
    from service.resources import passages

    monkeypatch.setattr(passages, "MAX_PASSAGE_CELLS", 100)
    map_id = await upload_doors(client)
    r = await client.get(f"/maps/{map_id}/passages", params={"robot_radius": RADIUS})
    assert r.status_code == 413, r.text
    assert r.json()["field"] == "map_id"
    assert "2048 x 2048" in r.json()["detail"]
    _, middles = doors_grid()
    row = round(middles[1][0])
    body = {"map_id": map_id, "start": [row, 70], "goal": [row, 180], "robot_radius": RADIUS}
    made = await client.post("/plan", json=body)
    assert made.status_code == 201, made.text
    assert made.json()["preview"]["passages"] is None

"""The fleet page ``/fleets/{fleet}/view`` in headless Chromium with no network: every robot with
its heading and path ahead, the passage and who holds it, following the fleet as it steps."""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import httpx
import orjson
from playwright.sync_api import Route, sync_playwright

from tests.service.browser import FLAGS, chromium
from tests.service.conftest import ROOT
from tests.service.test_fleets import F

FIGURE = ROOT / "docs" / "figures" / "fleet.png"


def _fleet(client: httpx.Client, name: str) -> tuple[str, str]:
    scenario = F.corridor_scenario(1, 0)
    map_id = client.post("/maps", json=F.map_body(scenario.robot_map)).json()["map_id"]
    ids = []
    for start, goal in scenario.robots:
        body = {"map_id": map_id, "start": list(start), "goal": list(goal),
                "robot_radius": scenario.radius, "fleet": name}  # fmt: skip
        answer = client.post("/plan", json=body)
        assert answer.status_code == 201, answer.text
        ids.append(answer.json()["plan_id"])
    return ids[0], ids[1]


def test_the_fleet_page_names_nothing_outside_the_service(live_url: str) -> None:
    with httpx.Client(base_url=live_url, trust_env=False) as client:
        assert client.get("/fleets/nobody/view").status_code == 404
        assert client.get("/fleets/bad name/view").status_code == 422
        _fleet(client, "page")
        r = client.get("/fleets/page/view")
        assert r.status_code == 200
        assert r.headers["content-type"].startswith("text/html")
        text = r.text.replace("http://www.w3.org/2000/svg", "")  # a name, not a load
        assert not re.search(r"(https?:)?//[a-z0-9]", text, re.IGNORECASE)
        fleet = client.get("/fleets/page?ahead=true").json()
        assert all(robot["poses"] == [] for robot in fleet["robots"])  # none stepped yet
        assert client.get("/fleets/page").json()["robots"][0]["poses"] is None


def test_the_fleet_page_shows_robots_routes_and_whom_they_wait_for_in_chromium(
    live_url: str, tmp_path: Path
) -> None:
    outside: list[str] = []

    def only_the_service(route: Route) -> None:
        if route.request.url.startswith(f"{live_url}/"):
            route.continue_()
        else:
            outside.append(route.request.url)
            route.abort()

    with (
        httpx.Client(base_url=live_url, trust_env=False, timeout=10) as client,
        sync_playwright() as playwright,
    ):
        a, b = _fleet(client, "door")
        browser = playwright.chromium.launch(
            executable_path=chromium(), args=[f for f in FLAGS if f != "--headless"]
        )
        try:
            page = browser.new_page(viewport={"width": 1000, "height": 520})
            page.route("**/*", only_the_service)
            page.goto(f"{live_url}/fleets/door/view")
            page.wait_for_function("document.body.dataset.live === 'true'", timeout=10_000)
            assert page.locator(".robot").count() == 2
            assert page.locator(".route").count() == 2  # solved as the robots joined
            held = None
            for seq in range(300):
                for plan_id in (a, b):
                    client.post(f"/plan/{plan_id}/step", json={"seq": seq})
                fleet = client.get("/fleets/door").json()
                waiting = [r for r in fleet["robots"] if r["waiting_for"]]
                if waiting:
                    held = waiting[0]
                    break
            assert held is not None, "no robot waited for the other at the corridor"
            waiter = held
            holder = waiter["waiting_for"]
            assert holder in (a, b)
            page.wait_for_function("document.querySelectorAll('.route').length >= 1", timeout=2000)
            page.wait_for_function(
                "document.querySelector(\".fleet-robot[data-plan-id='"
                + waiter["plan_id"]
                + "'] .robot\").dataset.waitingFor === "
                + orjson.dumps(holder).decode(),
                timeout=2000,
            )
            robot = page.locator(f".fleet-robot[data-plan-id='{waiter['plan_id']}'] .robot")
            assert robot.get_attribute("data-status") == "waiting"
            assert robot.get_attribute("data-waiting-for") == holder
            assert orjson.loads(robot.get_attribute("data-cell") or "") == waiter["position"]
            assert page.locator(".heading").count() == 2
            assert page.locator(".ahead").count() >= 1
            shot = tmp_path / "fleet.png"
            page.screenshot(path=str(shot))
            assert shot.read_bytes().startswith(b"\x89PNG")
            if os.environ.get("UPDATE_FIGURES"):  # docs/fleets.md's picture
                shutil.copyfile(shot, FIGURE)
        finally:
            browser.close()
    assert outside == []


def test_the_fleet_page_on_a_real_map_fills_the_window_with_a_scale_and_no_label_overlapping(
    live_url: str, ros: Path
) -> None:
    """Sixteen robots of 0.3 m on depot (604 x 307 cells) at 1400 x 1000: the map scaled to
    fill the window beside the robots' list (>= 60 %), a scale bar in meters, a legend of every
    layer, the robots numbered in their discs and listed aside, no two labels overlapping."""
    import planner

    depot = planner.read_ros_map(ros / "depot.yaml")
    scenario = F.random_scenario(depot, 16, 0, radius=0.3)
    with (
        httpx.Client(base_url=live_url, trust_env=False, timeout=60) as client,
        sync_playwright() as playwright,
    ):
        map_id = client.post("/maps", json=F.map_body(depot)).json()["map_id"]
        for start, goal in scenario.robots:
            body = {"map_id": map_id, "start": list(start), "goal": list(goal),
                    "robot_radius": 0.3, "fleet": "depot-page"}  # fmt: skip
            assert client.post("/plan", json=body).status_code == 201
        browser = playwright.chromium.launch(
            executable_path=chromium(), args=[f for f in FLAGS if f != "--headless"]
        )
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.goto(f"{live_url}/fleets/depot-page/view")
            page.wait_for_function("document.body.dataset.live === 'true'", timeout=10_000)
            box = page.locator("#frame").bounding_box()
            assert box is not None
            assert box["width"] * box["height"] >= 0.6 * 1400 * 1000, box
            assert box["x"] + box["width"] <= 1400.5
            assert page.locator("#scale-bar text").count() == 1
            assert (page.text_content("#scale-bar text") or "").endswith(" m")
            legend = page.text_content("#legend") or ""
            for layer in ("robot", "waiting", "arrived", "path ahead", "route", "goal", "scale"):
                assert layer in legend, layer
            assert page.locator("#list tbody tr").count() == 16
            # Read at once (the page redraws a few times a second).
            boxes = page.evaluate(
                "[...document.querySelectorAll('.label')].map((e) => {"
                " const r = e.getBoundingClientRect();"
                " return {x: r.x, y: r.y, width: r.width, height: r.height}; })"
            )
            assert len(boxes) == 16
            for i, a in enumerate(boxes):
                for b in boxes[i + 1 :]:
                    apart = (
                        a["x"] + a["width"] <= b["x"] or b["x"] + b["width"] <= a["x"]
                        or a["y"] + a["height"] <= b["y"] or b["y"] + b["height"] <= a["y"]
                    )  # fmt: skip
                    assert apart, (a, b)
        finally:
            browser.close()

"""The live viewer: ``/plan/{plan_id}/events`` streams one event per step, and
``/plan/{plan_id}/view``, in headless Chromium with no network, moves its robot as steps arrive."""

from __future__ import annotations

import math
import os
import re
import shutil
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import orjson
import pytest
from playwright.sync_api import Page, Route, sync_playwright

from tests.service.browser import FLAGS, chromium
from tests.service.conftest import ROOT

# An L-shaped way: along row 0 eastward, then down column 5 southward.
GRID = [[0] * 8] + [[1] * 5 + [0] * 3 for _ in range(7)]
PATH = [[0, c] for c in range(6)] + [[r, 5] for r in range(1, 6)]
FIGURE = ROOT / "docs" / "figures" / "viewer.png"


def new_plan(client: httpx.Client) -> str:
    body = {"grid": GRID, "start": [0, 0], "goal": [5, 5], "preset": "shortest"}
    r = client.post("/maps", json=body)
    assert r.status_code in (200, 201), r.text
    assert r.json()["plan"]["preview"]["path"] == PATH
    plan_id: str = r.json()["plan"]["plan_id"]
    return plan_id


def events(lines: Iterator[str]) -> Iterator[dict[str, Any]]:
    """The ``data:`` of each event of a server-sent event stream (comments skipped)."""
    data: list[str] = []
    for line in lines:
        if line.startswith("data:"):
            data.append(line[5:].strip())
        elif not line and data:
            yield orjson.loads("\n".join(data))
            data = []


def test_unknown_plans_have_no_view_and_no_events(live_url: str) -> None:
    with httpx.Client(base_url=live_url, trust_env=False) as client:
        for what in ("view", "events"):
            r = client.get(f"/plan/0123abcd/{what}")
            assert r.status_code == 404
            assert r.json()["code"] == "NOT_FOUND"


def test_the_page_names_nothing_outside_the_service(live_url: str) -> None:
    with httpx.Client(base_url=live_url, trust_env=False) as client:
        plan_id = new_plan(client)
        r = client.get(f"/plan/{plan_id}/view")
        assert r.status_code == 200
        assert r.headers["content-type"].startswith("text/html")
        assert not re.search(r"(https?:)?//[a-z0-9]", r.text, re.IGNORECASE)
        assert 'new EventSource("events")' in r.text
        # What the page loads, relative to it: its picture and its events.
        assert client.get(f"/plan/{plan_id}/render.png?cell=32").status_code == 200


def test_the_stream_has_one_event_per_step_within_2_s(live_url: str) -> None:
    with (
        httpx.Client(base_url=live_url, trust_env=False, timeout=10) as client,
        httpx.Client(base_url=live_url, trust_env=False, timeout=10) as watcher,
    ):
        plan_id = new_plan(client)
        with watcher.stream("GET", f"/plan/{plan_id}/events") as stream:
            assert stream.status_code == 200
            assert stream.headers["content-type"].startswith("text/event-stream")
            received = events(stream.iter_lines())
            for seq, obstacles in enumerate([[[7, 7]], [], [[6, 6], [7, 6]]]):
                answer = client.post(
                    f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": obstacles}
                ).json()
                sent = time.monotonic()
                event = next(received)
                assert time.monotonic() - sent < 2
                assert event["seq"] == seq
                assert event["position"] == answer["position"] == PATH[seq + 1]
                assert event["dynamic_obstacles"] == obstacles
                assert event["move"] == answer["move"] == "E"
            # A retried seq is answered, not stepped again, and no event again: the next event
            # is the next step's.
            retry = client.post(f"/plan/{plan_id}/step", json={"seq": 2, "dynamic_obstacles": []})
            assert retry.json()["seq"] == 2
            client.post(f"/plan/{plan_id}/step", json={"seq": 3, "dynamic_obstacles": []})
            assert next(received)["seq"] == 3


def _cell(page: Page) -> Any:
    return orjson.loads(page.get_attribute("#robot", "data-cell") or "null")


def _ahead(page: Page) -> tuple[list[list[float]], float | None]:
    """The path ahead as drawn (its polyline's points, board pixels) and the heading's yaw."""
    points = page.get_attribute("#ahead", "points") or ""
    drawn = [[float(v) for v in pair.split(",")] for pair in points.split()]
    assert page.get_attribute("#ahead", "data-count") == str(len(drawn))
    yaw = page.get_attribute("#heading", "data-yaw")
    return drawn, None if yaw is None else float(yaw)


def _check_ahead(page: Page, answer: dict[str, Any], cell: int = 32) -> None:
    """The answer's poses drawn through their points (meters to pixels: 1 m cells, origin 0),
    the heading from the first pose, along its yaw (y grows downwards on the page)."""
    drawn, yaw = _ahead(page)
    height = len(GRID)
    want = [[p["x"] * cell, (height - p["y"]) * cell] for p in answer["poses"]]
    assert len(drawn) == len(want)
    flat = [v for point in want for v in point]
    assert [v for point in drawn for v in point] == pytest.approx(flat, abs=0.01)
    first = answer["poses"][0]
    assert yaw == pytest.approx(first["yaw"])
    x1, y1, x2, y2 = (
        float(page.get_attribute("#heading", k) or "nan") for k in ("x1", "y1", "x2", "y2")
    )
    assert [x1, y1] == pytest.approx(want[0], abs=0.01)
    assert math.atan2(-(y2 - y1), x2 - x1) == pytest.approx(first["yaw"], abs=1e-6)


def _centre(page: Page) -> tuple[float, float]:
    page.wait_for_timeout(300)  # the robot glides for 0.15 s
    box = page.locator("#robot").bounding_box()
    assert box is not None, "#robot is not visible"
    assert box["width"] > 0
    assert box["height"] > 0
    return box["x"] + box["width"] / 2, box["y"] + box["height"] / 2


def test_the_page_follows_the_robot_live_in_chromium(live_url: str, tmp_path: Path) -> None:
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
        plan_id = new_plan(client)
        browser = playwright.chromium.launch(
            executable_path=chromium(), args=[f for f in FLAGS if f != "--headless"]
        )
        try:
            page = browser.new_page(viewport={"width": 600, "height": 520})
            page.route("**/*", only_the_service)
            page.goto(f"{live_url}/plan/{plan_id}/view")
            page.wait_for_function("document.body.dataset.live === 'true'", timeout=10_000)
            assert _cell(page) == [0, 0]
            assert page.locator(".dynamic-obstacle").count() == 0
            previous = _centre(page)

            def step(seq: int, obstacles: list[list[int]]) -> tuple[float, float]:
                body = {"seq": seq, "dynamic_obstacles": obstacles}
                answer = client.post(f"/plan/{plan_id}/step", json=body).json()
                want = orjson.dumps(answer["position"]).decode()
                page.wait_for_function(
                    f"document.getElementById('robot').dataset.cell === '{want}'", timeout=1000
                )
                marks = page.locator(".dynamic-obstacle")
                assert marks.count() == len(obstacles)
                cells = [
                    orjson.loads(marks.nth(i).get_attribute("data-cell") or "")
                    for i in range(len(obstacles))
                ]
                assert sorted(cells) == sorted(obstacles)
                _check_ahead(page, answer)
                return _centre(page)

            for seq in range(5):  # eastward: the robot goes right
                obstacles = [[7, 7], [6 - seq % 2, 6]] if seq % 2 else [[3, 7]]
                here = step(seq, obstacles)
                assert here[0] > previous[0] + 1
                assert here[1] == pytest.approx(previous[1], abs=1)
                previous = here
            assert _cell(page) == [0, 5]
            for seq in range(5, 8):  # southward: the robot goes down
                here = step(seq, [[seq - 3, 7]])
                assert here[1] > previous[1] + 1
                assert here[0] == pytest.approx(previous[0], abs=1)
                previous = here
            assert _cell(page) == [3, 5]
            # A robot reporting its real pose: the path ahead starts there, along its heading.
            body = {"seq": 8, "position": {"x": 5.3, "y": 4.6, "yaw": 2.0}}
            answer = client.post(f"/plan/{plan_id}/step", json=body).json()
            page.wait_for_function(
                "document.getElementById('heading').dataset.yaw === '2'", timeout=1000
            )
            _check_ahead(page, answer)
            assert len(answer["poses"]) > 3
            shot = tmp_path / "viewer.png"
            page.screenshot(path=str(shot))
            assert shot.read_bytes().startswith(b"\x89PNG")
            if os.environ.get("UPDATE_FIGURES"):  # the README's picture
                shutil.copyfile(shot, FIGURE)
        finally:
            browser.close()
    assert outside == []

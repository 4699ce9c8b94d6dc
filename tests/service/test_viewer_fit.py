"""The live viewer in headless Chromium (no network): a real map fills the window whatever its
size, and a page opened after steps were taken says where the robot stands, in meters to go."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import pytest
from playwright.sync_api import Browser, FloatRect, Page, sync_playwright

from tests.service.browser import FLAGS, chromium
from tests.service.conftest import ROOT, random_map
from tests.service.test_viewer import new_plan

VIEWPORT = {"width": 1280, "height": 800}


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    with sync_playwright() as playwright:
        launched = playwright.chromium.launch(
            executable_path=chromium(), args=[f for f in FLAGS if f != "--headless"]
        )
        try:
            yield launched
        finally:
            launched.close()


def _open(browser: Browser, url: str) -> Page:
    page = browser.new_page(viewport=VIEWPORT)  # type: ignore[arg-type]
    page.goto(url)
    page.wait_for_function("document.body.dataset.live === 'true'", timeout=10_000)
    return page


@pytest.mark.parametrize(("height", "width"), [(300, 500), (900, 240), (8, 8)])
def test_the_map_fills_the_window(live_url: str, browser: Browser, height: int, width: int) -> None:
    """A 500 x 300 map comes at 1 pixel a cell: it was drawn 500 pixels wide in the window's
    corner. Now it is scaled to the window's width or to the height left below the legend (and
    above the scale bar)."""
    grid = random_map(height, width, 0.1, seed=height).tolist()
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as client:
        body = {
            "grid": grid,
            "start": [0, 0],
            "goal": [height - 1, width - 1],
            "preset": "shortest",
        }
        r = client.post("/maps", json=body)
        assert r.status_code in (200, 201), r.text
        plan_id = r.json()["plan"]["plan_id"]
    page = _open(browser, f"{live_url}/plan/{plan_id}/view")
    try:
        board = page.locator("#board").bounding_box()
        robot = page.locator("#robot").bounding_box()
        assert board is not None
        assert robot is not None
        right, bottom = board["x"] + board["width"], board["y"] + board["height"]
        assert right <= VIEWPORT["width"] + 0.5
        assert bottom <= VIEWPORT["height"] + 0.5
        room_x = VIEWPORT["width"] - 2 * board["x"]
        room_y = VIEWPORT["height"] - board["y"] - 16 - 26  # the scale bar below it
        filled = max(board["width"] / room_x, board["height"] / room_y)
        assert filled > 0.97, (board, filled)
        assert board["width"] / board["height"] == pytest.approx(width / height, rel=0.02)
        assert robot["width"] >= 6  # the robot is seen at any scale
        page.set_viewport_size({"width": 700, "height": 500})  # and it follows the window
        page.wait_for_timeout(100)
        smaller = page.locator("#board").bounding_box()
        assert smaller is not None
        assert smaller["x"] + smaller["width"] <= 700.5
        assert smaller["y"] + smaller["height"] <= 500.5
    finally:
        page.close()


def test_a_page_opened_after_steps_says_where_the_robot_is(live_url: str, browser: Browser) -> None:
    with httpx.Client(base_url=live_url, trust_env=False, timeout=10) as client:
        plan_id = new_plan(client)
        page = _open(browser, f"{live_url}/plan/{plan_id}/view")
        try:
            assert page.text_content("#status") == "waiting for the first step"
        finally:
            page.close()
        for seq in range(10):
            r = client.post(f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": []})
            assert r.status_code == 200
        last = r.json()
        page = _open(browser, f"{live_url}/plan/{plan_id}/view")
        try:
            status = page.text_content("#status") or ""
            assert "waiting" not in status
            assert status.startswith(
                f"step 9: {last['move']} to [{', '.join(map(str, last['position']))}]"
            )
            assert status.endswith(f", {last['remaining_m']:.2f} m to go")
            # A live step says the same, with its unit.
            client.post(f"/plan/{plan_id}/step", json={"seq": 10, "dynamic_obstacles": []})
            page.wait_for_function(
                "document.getElementById('status').textContent.startsWith('step 10:')",
                timeout=2000,
            )
            assert (page.text_content("#status") or "").endswith(" m to go")
        finally:
            page.close()


DEPOT = ROOT / "examples" / "maps"
LARGE = {"width": 1400, "height": 1000}


def _boxes_overlap(a: FloatRect, b: FloatRect) -> bool:
    return (
        a["x"] < b["x"] + b["width"]
        and b["x"] < a["x"] + a["width"]
        and a["y"] < b["y"] + b["height"]
        and b["y"] < a["y"] + a["height"]
    )


def test_a_robot_map_reads_at_1400_by_1000(live_url: str, browser: Browser) -> None:
    """``depot``, the largest of the shared ROS maps, in a 1400 x 1000 window: the map fills
    most of it, a scale bar says how long a round number of meters is on the screen, the
    legend names every layer, passage labels never overlap (the others are listed), and the
    wheel zooms and a drag pans."""
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as client:
        files = {
            "yaml": (DEPOT / "depot.yaml").read_bytes(),
            "image": (DEPOT / "depot.pgm").read_bytes(),
        }
        map_id = client.post("/maps", files=files).json()["map_id"]
        body = {
            "map_id": map_id, "start": {"x": 6.8, "y": 14.0}, "goal": {"x": 25.0, "y": 4.5},
            "robot_radius": 0.3, "name": "forklift 3",
        }  # fmt: skip
        r = client.post("/plan", json=body)
        assert r.status_code == 201, r.text
        plan = r.json()
        passages = client.get(f"/maps/{map_id}/passages", params={"robot_radius": 0.3}).json()
    page = browser.new_page(viewport=LARGE)  # type: ignore[arg-type]
    try:
        page.goto(f"{live_url}/plan/{plan['plan_id']}/view")
        page.wait_for_function("document.body.dataset.passages !== undefined", timeout=10_000)
        assert (page.text_content("h1") or "").startswith("forklift 3 (plan ")  # its name
        board = page.locator("#frame").bounding_box()
        assert board is not None
        assert board["width"] * board["height"] >= 0.6 * LARGE["width"] * LARGE["height"], board
        # The scale bar: its length on the screen is its meters at the board's scale.
        bar = page.locator("#scale-bar")
        meters = float(bar.get_attribute("data-meters") or "nan")
        pixels = float(bar.get_attribute("data-pixels") or "nan")
        scale = float(page.locator("#board").get_attribute("data-scale") or "nan")
        cell = pixels / meters / scale * 0.05  # the board's pixels a cell
        assert 80 <= pixels <= 200
        assert cell == pytest.approx(round(cell), rel=1e-6)
        legend = page.text_content("#legend") or ""
        for layer in ("poses (smooth path)", "margin", "planned path", "start", "goal",
                      "narrow passage", "scale bar", "unknown", "blocked"):  # fmt: skip
            assert layer in legend, layer
        # Labels: none overlaps another; every passage is labelled or listed.
        count = len(passages["passages"])
        assert page.locator(".passage").count() == count > 1
        labels = [
            box
            for i in range(count)
            if (box := page.locator(".passage text").nth(i).bounding_box()) is not None
            and page.locator(".passage text").nth(i).is_visible()
        ]
        listed = page.locator("#passage-list span").count()
        assert len(labels) + listed == count
        for i, a in enumerate(labels):
            for b in labels[i + 1 :]:
                assert not _boxes_overlap(a, b), (a, b)
        for box in labels:  # 12 pixels high on the screen, whatever the scale
            assert 8 <= box["height"] <= 20, box
        # Zoom with the wheel over the map's middle, then pan with a drag.
        middle = (board["x"] + board["width"] / 2, board["y"] + board["height"] / 2)
        page.mouse.move(*middle)
        page.mouse.wheel(0, -300)
        page.wait_for_function("Number(document.getElementById('frame').dataset.zoom) > 1")
        zoomed = float(page.locator("#board").get_attribute("data-scale") or "nan")
        assert zoomed > scale
        assert float(bar.get_attribute("data-meters") or "nan") <= meters
        before = page.locator("#board").bounding_box()
        page.mouse.down()
        page.mouse.move(middle[0] + 120, middle[1] + 60)
        page.mouse.up()
        after = page.locator("#board").bounding_box()
        assert before is not None
        assert after is not None
        assert after["x"] - before["x"] == pytest.approx(120, abs=2)
        assert after["y"] - before["y"] == pytest.approx(60, abs=2)
    finally:
        page.close()

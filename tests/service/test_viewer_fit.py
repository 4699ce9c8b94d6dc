"""The live viewer in headless Chromium (no network): a real map fills the window whatever its
size, and a page opened after steps were taken says where the robot stands, in meters to go."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import pytest
from playwright.sync_api import Browser, Page, sync_playwright

from tests.service.browser import FLAGS, chromium
from tests.service.conftest import random_map
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
    corner. Now it is scaled to the window's width or to the height left below the legend."""
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
        room_y = VIEWPORT["height"] - board["y"] - 16
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

"""The live marks on the plan page and the fleet page, in headless Chromium with no network:
a scan reported to the map shows on both within a second or two, and its clearing too."""

from __future__ import annotations

import httpx
from playwright.sync_api import Page, sync_playwright

from tests.service.browser import FLAGS, chromium
from tests.service.test_live import BOX, MAP, PLAN, _scan

POSE = {"x": 1.05, "y": 1.45, "yaw": 0.0}


def _marks_shown(page: Page, count: int) -> int:
    page.wait_for_function(f"document.body.dataset.liveMarks === '{count}'", timeout=5000)
    return page.locator(".live-mark").count()


def test_both_pages_draw_the_live_marks(live_url: str) -> None:
    with (
        httpx.Client(base_url=live_url, trust_env=False, timeout=30) as client,
        sync_playwright() as playwright,
    ):
        map_id = client.post("/maps", json=MAP).json()["map_id"]
        plan_id = client.post("/plan", json={"map_id": map_id, **PLAN}).json()["plan_id"]
        fleet = {"map_id": map_id, **PLAN, "fleet": "scanned"}
        assert client.post("/plan", json=fleet).status_code == 201
        browser = playwright.chromium.launch(
            executable_path=chromium(), args=[f for f in FLAGS if f != "--headless"]
        )
        try:
            plan_page = browser.new_page(viewport={"width": 700, "height": 500})
            plan_page.goto(f"{live_url}/plan/{plan_id}/view")
            fleet_page = browser.new_page(viewport={"width": 700, "height": 500})
            fleet_page.goto(f"{live_url}/fleets/scanned/view")
            seen = {"scan": _scan((1.05, 1.45, 0.0), [BOX]), "scan_pose": POSE}
            marks = client.post(f"/maps/{map_id}/observations", json=seen).json()["marks"]
            assert marks > 5
            assert _marks_shown(plan_page, marks) == marks
            assert _marks_shown(fleet_page, marks) == marks
            cleared = {"scan": _scan((1.05, 1.45, 0.0), []), "scan_pose": POSE}
            assert client.post(f"/maps/{map_id}/observations", json=cleared).json()["marks"] == 0
            assert _marks_shown(plan_page, 0) == 0
            assert _marks_shown(fleet_page, 0) == 0
        finally:
            browser.close()

"""The live viewer of a robot with a footprint, in headless Chromium (no network): its outline
along the path ahead of each step (``.outline``, every 0.3 m and at both ends), over the plan's
picture, which outlines it along the plan's poses (orange where the car reverses)."""

from __future__ import annotations

import io
import math

import httpx
import numpy as np
from PIL import Image
from playwright.sync_api import sync_playwright

from planner.render_shapes import REVERSE
from tests import naive_shapes
from tests.naive_shapes import RECTANGLE
from tests.service.browser import FLAGS, chromium


def _outlines(poses: list[dict[str, float]]) -> int:
    """How many outlines the page draws along ``poses``: one every 0.3 m, and the last."""
    count, along, due = 0, 0.0, 0.0
    for i, p in enumerate(poses):
        if i:
            along += math.hypot(p["x"] - poses[i - 1]["x"], p["y"] - poses[i - 1]["y"])
        if along >= due or i == len(poses) - 1:
            count, due = count + 1, along + 0.3
    return count


def test_the_page_outlines_the_footprint_ahead(live_url: str) -> None:
    bay, start, goal = naive_shapes.parking_bay()
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as client:
        r = client.post("/maps", json={"occupancy_grid": bay.to_occupancy_grid()})
        body = {
            "map_id": r.json()["map_id"], "start": start, "goal": goal, "footprint": RECTANGLE,
            "motion": "car_reverse", "min_turning_radius": 0.5,
        }  # fmt: skip
        r = client.post("/plan", json=body)
        assert r.status_code == 201, r.text
        plan_id = r.json()["plan_id"]
        picture = client.get(f"/plan/{plan_id}/render.png", params={"cell": 6})
        rgb = np.asarray(Image.open(io.BytesIO(picture.content)).convert("RGB"))
        assert (rgb == REVERSE).all(axis=2).sum() > 100  # it backs into the bay
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path=chromium(), args=[f for f in FLAGS if f != "--headless"]
            )
            try:
                page = browser.new_page(viewport={"width": 900, "height": 600})
                page.goto(f"{live_url}/plan/{plan_id}/view")
                page.wait_for_function("document.body.dataset.live === 'true'", timeout=10_000)
                assert page.locator(".outline").count() == 0  # no step yet
                answer = client.post(f"/plan/{plan_id}/step", json={"seq": 0}).json()
                want = _outlines(answer["poses"])
                assert want > 3
                page.wait_for_function(
                    f"document.querySelectorAll('.outline').length === {want}", timeout=2000
                )
                first = page.locator(".outline").first.get_attribute("points") or ""
                assert len(first.split()) == len(RECTANGLE)
            finally:
                browser.close()

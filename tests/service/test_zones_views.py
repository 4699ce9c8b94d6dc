"""Zones through the Python client (sync and async, JSON and a keepout mask's files) and in
the live viewer in headless Chromium (keepout hatched, speed zones labelled, the status line's
speed cap), each against a live uvicorn."""

from __future__ import annotations

import asyncio
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import sync_playwright

from service.client import AsyncPlannerClient, NotFoundError, PlannerClient, ValidationError
from tests.service.browser import FLAGS, chromium
from tests.service.test_zones import points


def test_the_client_adds_zones(live_url: str, tmp_path: Path) -> None:
    """``add_zones`` through the sync and the async client: polygons as JSON (points as dicts
    or pairs), and a keepout mask's YAML file with its image beside it."""
    grid = [[0] * 20 for _ in range(10)]
    pixels = np.full((10, 20), 254, dtype=np.uint8)
    pixels[2:5, 3:7] = 0
    Image.fromarray(pixels).save(tmp_path / "keepout.png")
    (tmp_path / "keepout.yaml").write_text(
        "image: keepout.png\nresolution: 0.5\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.25\n"
    )
    with PlannerClient(live_url) as client:
        base = client.upload_map(grid=grid, resolution=0.5)
        zoned = client.add_zones(
            base.map_id,
            keepout=[[(1.0, 1.0), (3.0, 1.0), (3.0, 3.0)]],
            speed=[{"polygon": [{"x": 5, "y": 0}, {"x": 8, "y": 0}, {"x": 8, "y": 4}],
                    "max_speed": 0.4}],
        )  # fmt: skip
        assert zoned.created is True
        assert zoned.zones is not None
        assert zoned.zones.base_map_id == base.map_id
        assert zoned.zones.speed[0].max_speed == 0.4
        assert client.get_map(zoned.map_id) == zoned.model_copy(update={"created": None})
        masked = client.add_zones(base.map_id, yaml=tmp_path / "keepout.yaml")
        assert masked.occupied_cells == 12
        assert masked.zones is not None
        assert masked.zones.keepout_masks[0].cells == 12
        with pytest.raises(NotFoundError):
            client.add_zones("0" * 64, keepout=[[(1, 1), (3, 1), (3, 3)]])
        with pytest.raises(ValidationError) as info:
            client.add_zones(base.map_id, keepout=[[(1, 1), (3, 3), (3, 1), (1, 3)]])
        assert info.value.field == "keepout[0]"

    async def run() -> None:
        async with AsyncPlannerClient(live_url) as client:
            again = await client.add_zones(
                base.map_id, keepout=[[(1.0, 1.0), (3.0, 1.0), (3.0, 3.0)]],
                speed=[{"polygon": [(5, 0), (8, 0), (8, 4)], "max_speed": 0.4}],
            )  # fmt: skip
            assert again.map_id == zoned.map_id
            assert again.created is False

    asyncio.run(run())


def test_the_viewer_draws_the_zones_in_chromium(live_url: str) -> None:
    """The live page of a plan on a zoned map shows its keepout polygon hatched and its speed
    zone with its max speed, placed by the frame's formula; a plan on an unzoned map shows
    none, nor their keys."""
    grid = [[0] * 20 for _ in range(10)]
    keepout = [(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)]
    slow = [(6.0, 0.5), (9.0, 0.5), (9.0, 4.5)]
    with httpx.Client(base_url=live_url, trust_env=False, timeout=10) as client:
        base_id = client.post("/maps", json={"grid": grid, "resolution": 0.5}).json()["map_id"]
        body = {
            "keepout": [points(keepout)],
            "speed": [{"polygon": points(slow), "max_speed": 0.3}],
        }
        zoned_id = client.post(f"/maps/{base_id}/zones", json=body).json()["map_id"]
        ends = {"start": {"x": 0.5, "y": 4.5}, "goal": {"x": 9.5, "y": 0.5}}
        zoned_plan = client.post("/plan", json={"map_id": zoned_id, **ends}).json()["plan_id"]
        plain_plan = client.post("/plan", json={"map_id": base_id, **ends}).json()["plan_id"]
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path=chromium(), args=[f for f in FLAGS if f != "--headless"]
            )
            try:
                page = browser.new_page(viewport={"width": 900, "height": 600})
                page.goto(f"{live_url}/plan/{zoned_plan}/view")
                page.wait_for_function("document.body.dataset.live === 'true'", timeout=10_000)
                assert page.locator("polygon.keepout").count() == 1
                assert page.locator("polygon.speed-zone").count() == 1
                label = page.locator("text.speed-label")
                assert label.text_content() == "0.3 m/s"
                assert label.get_attribute("data-max-speed") == "0.3"
                cell = page.evaluate("JSON.parse(document.getElementById('plan-data')"
                                     ".textContent).cell")  # fmt: skip
                drawn = page.locator("polygon.keepout").get_attribute("points") or ""
                xy = [tuple(float(v) for v in p.split(",")) for p in drawn.split()]
                # x meters -> x / 0.5 cells from the left; y meters -> (10 - y / 0.5) cells down.
                want = [(x / 0.5 * cell, (10 - y / 0.5) * cell) for x, y in keepout]
                np.testing.assert_allclose(xy, want, atol=0.01)
                assert page.locator(".zone-key").count() == 2
                # Stepped into the speed zone, the status line says the cap.
                for seq in range(40):
                    answer = client.post(f"/plan/{zoned_plan}/step", json={"seq": seq}).json()
                    if answer["poses"] and "max_speed" in answer["poses"][0]:
                        break
                else:
                    raise AssertionError("the robot never stood in the speed zone")
                page.wait_for_function(
                    "document.getElementById('status').textContent"
                    ".includes('in a speed zone: at most 0.3 m/s')",
                    timeout=2000,
                )
                page.goto(f"{live_url}/plan/{plain_plan}/view")
                page.wait_for_function("document.body.dataset.live === 'true'", timeout=10_000)
                assert page.locator("polygon").count() == 0
                assert page.locator(".zone-key").count() == 0
            finally:
                browser.close()

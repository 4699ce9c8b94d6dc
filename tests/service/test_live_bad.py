"""Bad scans against a real server (uvicorn on 127.0.0.1): each a 4xx naming its field, fast,
never a 5xx; a plain grid takes no scan."""

from __future__ import annotations

import math
import time
from typing import Any

import httpx
import pytest

from tests.service.test_live import MAP

POSE = {"x": 1.05, "y": 1.45, "yaw": 0.0}
GOOD: dict[str, Any] = {
    "angle_min": -math.pi,
    "angle_increment": 2 * math.pi / 360,
    "range_min": 0.05,
    "range_max": 8.0,
    "ranges": [1.0] * 360,
}


@pytest.fixture(scope="module")
def ids(live_url: str) -> dict[str, str]:
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as client:
        robot = client.post("/maps", json=MAP).json()["map_id"]
        plain = client.post("/maps", json={"grid": [[0, 0, 0], [0, 0, 0]]}).json()["map_id"]
        plan = client.post("/plan", json={"map_id": plain, "start": [0, 0], "goal": [1, 2]})
        return {"robot": robot, "plain": plain, "plain_plan": plan.json()["plan_id"]}


def _post(live_url: str, path: str, body: Any) -> httpx.Response:
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as client:
        return client.post(path, json=body)


@pytest.mark.parametrize(
    ("scan", "field"),
    [
        ({**GOOD, "ranges": ["far", 1.0]}, "ranges"),
        ({**GOOD, "ranges": [[1.0]]}, "ranges"),
        ({**GOOD, "ranges": [True]}, "ranges"),
        ({**GOOD, "angle_increment": 0.1, "ranges": [1.0] * 100}, "angle_increment"),
        ({**GOOD, "range_min": 9.0}, "range_min"),
        ({**GOOD, "range_max": -1.0}, "range_max"),
        ({**GOOD, "ranges": []}, "ranges"),
        ({k: v for k, v in GOOD.items() if k != "range_max"}, "range_max"),
    ],
)
def test_a_bad_scan_is_a_422_naming_its_field(
    live_url: str, ids: dict[str, str], scan: dict[str, Any], field: str
) -> None:
    r = _post(live_url, f"/maps/{ids['robot']}/observations", {"scan": scan, "scan_pose": POSE})
    assert r.status_code == 422, r.text
    assert field in r.text


def test_a_hundred_thousand_ranges_are_refused_within_a_second(
    live_url: str, ids: dict[str, str]
) -> None:
    scan = {**GOOD, "angle_increment": 1e-5, "ranges": [1.0] * 100_000}
    started = time.perf_counter()
    r = _post(live_url, f"/maps/{ids['robot']}/observations", {"scan": scan, "scan_pose": POSE})
    assert time.perf_counter() - started < 1.0
    assert r.status_code in (413, 422), r.text
    assert "ranges" in r.text


def test_a_scan_on_a_plain_grid_is_a_422_naming_scan(live_url: str, ids: dict[str, str]) -> None:
    pose = {"x": 0.5, "y": 0.5, "yaw": 0.0}
    r = _post(live_url, f"/maps/{ids['plain']}/observations", {"scan": GOOD, "scan_pose": pose})
    assert r.status_code == 422, r.text
    assert r.json()["detail"].startswith("scan:")
    step = {"position": {"x": 0.5, "y": 1.5, "yaw": 0.0}, "scan": GOOD}
    r = _post(live_url, f"/plan/{ids['plain_plan']}/step", step)
    assert r.status_code == 422, r.text
    assert r.json()["detail"].startswith("scan:")


def test_a_pose_off_the_map_and_unknown_maps(live_url: str, ids: dict[str, str]) -> None:
    far = {"x": 100.0, "y": 1.0, "yaw": 0.0}
    r = _post(live_url, f"/maps/{ids['robot']}/observations", {"scan": GOOD, "scan_pose": far})
    assert r.status_code == 422, r.text
    assert "scan_pose" in r.text
    r = _post(live_url, "/maps/nope/observations", {"scan": GOOD, "scan_pose": POSE})
    assert r.status_code == 404, r.text
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as client:
        assert client.get("/maps/nope/live").status_code == 404
        assert client.get("/maps/nope/live.png").status_code == 404
        assert client.get(f"/maps/{ids['robot']}/live").status_code == 200


def test_the_client_reports_a_scan_and_reads_the_marks(live_url: str) -> None:
    from service.client import PlannerClient
    from tests.service.test_live import BOX, _scan

    with PlannerClient(live_url) as client:
        info = client.upload_map(**MAP)
        seen = client.observe(info.map_id, _scan((1.05, 1.45, 0.0), [BOX]), POSE)
        live = client.live(info.map_id)
        assert seen.marks == len(live.cells) > 5
        assert len(live.points) == len(live.cells)
        assert client.render_live(info.map_id, cell=2)[:4] == b"\x89PNG"

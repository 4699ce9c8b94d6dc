"""The live layer over HTTP (docs/live.md): a scan's marks where its rays hit, cleared by a
later scan without the object, never the map's walls; another robot of the tenant stepping
around them at once, another tenant not seeing them; a step's own scan; bad scans."""

from __future__ import annotations

import asyncio
import itertools
import math
from typing import Any

import httpx
import numpy as np
import pytest

import planner
from service.config import Settings
from service.main import create_app
from tests.scripts import load_benchmark
from tests.service.conftest import running

world = load_benchmark("live_world")

RES = 0.1
H, W = 30, 60


def _grid() -> np.ndarray:
    grid = np.zeros((H, W), dtype=np.int64)
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 1
    return grid


GRID = _grid()
FRAME = planner.MapFrame((H, W), RES)
BOX = world.Box(2.75, 1.15, 3.25, 1.85)  # on the middle row, between the robots and the goal
MAP = {"grid": GRID.tolist(), "resolution": RES, "origin": [0.0, 0.0, 0.0]}
RADIUS = 0.15
PLAN = {"start": {"x": 0.55, "y": 1.55}, "goal": {"x": 5.45, "y": 1.55}, "robot_radius": RADIUS}


@pytest.fixture
def settings() -> Settings:
    return Settings(pool_size=2, api_keys="ka,kb")


A = {"X-API-Key": "ka"}
B = {"X-API-Key": "kb"}


def _scan(pose: tuple[float, float, float], boxes: list[Any], rays: int = 360) -> dict[str, Any]:
    scan: dict[str, Any] = world.cast(GRID == 1, FRAME, pose, boxes, rays=rays, range_max=8.0)
    return scan


async def _map(client: httpx.AsyncClient, headers: dict[str, str]) -> str:
    r = await client.post("/maps", json=MAP, headers=headers)
    assert r.status_code in (200, 201), r.text
    map_id: str = r.json()["map_id"]
    return map_id


async def _live(client: httpx.AsyncClient, map_id: str, headers: dict[str, str]) -> Any:
    r = await client.get(f"/maps/{map_id}/live", headers=headers)
    assert r.status_code == 200, r.text
    return r.json()


@pytest.mark.anyio
async def test_marks_match_the_hits_and_a_later_scan_clears_them(
    client: httpx.AsyncClient,
) -> None:
    map_id = await _map(client, A)
    pose = (1.05, 1.45, 0.0)
    scan = _scan(pose, [BOX])
    body = {"scan": scan, "scan_pose": {"x": pose[0], "y": pose[1], "yaw": pose[2]}}
    r = await client.post(f"/maps/{map_id}/observations", json=body, headers=A)
    assert r.status_code == 200, r.text
    seen = r.json()
    live = await _live(client, map_id, A)
    cells = np.array(live["cells"]).reshape(-1, 2)
    assert seen["marks"] == len(cells) > 5
    # Within a cell: every mark beside a cell a return fell in, and every return's cell that
    # is not the map's wall (never a mark) beside a mark.
    hits = FRAME.cells(world.hit_points(scan, pose))
    walls = {tuple(c) for c in np.argwhere(GRID == 1).tolist()}
    off_walls = np.array([c for c in hits.tolist() if tuple(c) not in walls])
    assert _chebyshev(cells, hits).max() <= 1
    assert _chebyshev(off_walls, cells).max() <= 1
    # ... which are the box's face toward the sensor, within a cell.
    for x, y in live["points"]:
        dx = max(BOX.x0 - x, 0.0, x - BOX.x1)
        dy = max(BOX.y0 - y, 0.0, y - BOX.y1)
        assert math.hypot(dx, dy) <= RES * math.sqrt(2) / 2 + 1e-9
    assert not walls & {tuple(c) for c in cells.tolist()}
    # The box gone: the next scan's rays cross its cells and clear them; the walls stay.
    r = await client.post(
        f"/maps/{map_id}/observations", json={**body, "scan": _scan(pose, [])}, headers=A
    )
    assert r.json()["marks"] == 0
    assert (await _live(client, map_id, A))["cells"] == []
    meta = (await client.get(f"/maps/{map_id}", headers=A)).json()
    assert meta["occupied_cells"] == int(GRID.sum())
    png = await client.get(f"/maps/{map_id}/live.png", headers=A)
    assert png.status_code == 200
    assert png.content[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.anyio
async def test_another_robot_steps_around_the_marks_and_another_tenant_sees_none(
    client: httpx.AsyncClient,
) -> None:
    map_id = await _map(client, A)
    r = await client.post("/plan", json={"map_id": map_id, **PLAN}, headers=A)
    assert r.status_code == 201, r.text
    plan_id = r.json()["plan_id"]
    first = (await client.post(f"/plan/{plan_id}/step", json={}, headers=A)).json()
    assert _crosses(first["poses"], BOX)  # straight along the row: through where the box is
    # A second robot (here: a fixed sensor) sees the box.
    pose = {"x": 1.05, "y": 1.45, "yaw": 0.0}
    body = {"scan": _scan((1.05, 1.45, 0.0), [BOX]), "scan_pose": pose, "robot_radius": 0.15}
    assert (await client.post(f"/maps/{map_id}/observations", json=body, headers=A)).is_success
    second = (await client.post(f"/plan/{plan_id}/step", json={}, headers=A)).json()
    assert second["poses"], second
    assert not _crosses(second["poses"], BOX, margin=RADIUS)
    assert second["remaining_m"] > first["remaining_m"] - 0.2  # the way round is longer
    # Another tenant's robot on the same map sees nothing of it.
    other = await _map(client, B)
    assert other == map_id
    assert (await _live(client, map_id, B))["cells"] == []
    r = await client.post("/plan", json={"map_id": map_id, **PLAN}, headers=B)
    theirs = (await client.post(f"/plan/{r.json()['plan_id']}/step", json={}, headers=B)).json()
    assert _crosses(theirs["poses"], BOX)


@pytest.mark.anyio
async def test_a_steps_own_scan_marks_before_it_decides(client: httpx.AsyncClient) -> None:
    map_id = await _map(client, A)
    r = await client.post("/plan", json={"map_id": map_id, **PLAN}, headers=A)
    plan_id = r.json()["plan_id"]
    pose = {"x": 0.55, "y": 1.55, "yaw": 0.0}
    scan = _scan((0.55, 1.55, 0.0), [BOX])
    step = {"seq": 0, "position": pose, "scan": scan}
    answer = (await client.post(f"/plan/{plan_id}/step", json=step, headers=A)).json()
    assert not _crosses(answer["poses"], BOX, margin=RADIUS), answer
    assert (await _live(client, map_id, A))["cells"]
    # A scan without a pose to take it at: the cell position has no yaw.
    bad = {"seq": 1, "position": answer["position"], "scan": scan}
    r = await client.post(f"/plan/{plan_id}/step", json=bad, headers=A)
    assert r.status_code == 422
    assert "scan_pose" in r.text


def _chebyshev(cells: np.ndarray, near: np.ndarray) -> np.ndarray:
    """Each of ``cells``' Chebyshev distance to the nearest of ``near``."""
    out: np.ndarray = np.abs(cells[:, None, :] - near[None, :, :]).max(axis=2).min(axis=1)
    return out


def _crosses(poses: list[dict[str, float]], box: Any, margin: float = 0.0) -> bool:
    """Whether the poses' polyline comes within ``margin`` of the box (sampled finely)."""
    xy = np.array([[p["x"], p["y"]] for p in poses])
    for a, b in itertools.pairwise(xy):
        for t in np.linspace(0.0, 1.0, 20):
            x, y = a + t * (b - a)
            dx = max(box.x0 - x, 0.0, x - box.x1)
            dy = max(box.y0 - y, 0.0, y - box.y1)
            if math.hypot(dx, dy) <= margin:
                return True
    return False


@pytest.mark.anyio
async def test_a_fleet_robot_takes_the_marks_as_obstacles(client: httpx.AsyncClient) -> None:
    map_id = await _map(client, A)
    body = {"map_id": map_id, **PLAN, "fleet": "scanned"}
    r = await client.post("/plan", json=body, headers=A)
    assert r.status_code == 201, r.text
    plan_id = r.json()["plan_id"]
    pose = {"x": 1.05, "y": 1.45, "yaw": 0.0}
    seen = {"scan": _scan((1.05, 1.45, 0.0), [BOX]), "scan_pose": pose, "robot_radius": RADIUS}
    assert (await client.post(f"/maps/{map_id}/observations", json=seen, headers=A)).is_success
    marked = {tuple(c) for c in (await _live(client, map_id, A))["cells"]}
    status, seq = "", 0
    for seq in range(300):
        if seq % 10 == 0:  # the sensor keeps seeing the box: its marks stay
            await client.post(f"/maps/{map_id}/observations", json=seen, headers=A)
        r = await client.post(f"/plan/{plan_id}/step", json={"seq": seq}, headers=A)
        assert r.status_code == 200, r.text
        answer = r.json()
        status = answer["status"]
        assert tuple(answer["position"]) not in marked
        x, y = answer["position_xy"]
        gap = math.hypot(max(BOX.x0 - x, 0.0, x - BOX.x1), max(BOX.y0 - y, 0.0, y - BOX.y1))
        assert gap > RADIUS - RES / 2, answer
        if status == "arrived":
            break
    assert status == "arrived", (seq, answer)


@pytest.mark.anyio
async def test_marks_lapse_after_the_persistence_setting() -> None:
    app = create_app(Settings(pool_size=1, obstacle_persistence_seconds=0.4))
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            map_id = await _map(c, {})
            pose = {"x": 1.05, "y": 1.45, "yaw": 0.0}
            body = {"scan": _scan((1.05, 1.45, 0.0), [BOX]), "scan_pose": pose}
            assert (await c.post(f"/maps/{map_id}/observations", json=body)).json()["marks"] > 5
            live = await _live(c, map_id, {})
            assert live["persistence_seconds"] == 0.4
            assert live["cells"]
            await asyncio.sleep(0.6)
            assert (await _live(c, map_id, {}))["cells"] == []

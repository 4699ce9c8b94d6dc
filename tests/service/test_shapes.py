"""Robot shapes and motion over HTTP (API.md "Robot shapes and motion"): a footprint's and a
car's plans, poses free by shapely's exact check with their ``direction``, the parking bay
with a cusp, a plan read back from its record, and bad footprints and motions refused with
422 naming the field."""

from __future__ import annotations

import math
import typing
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

import planner
from service.config import Settings
from tests import naive_shapes
from tests.naive_shapes import RECTANGLE

pytestmark = pytest.mark.anyio


@pytest.fixture
def settings() -> Settings:
    return Settings(pool_size=2)


async def _upload(client: httpx.AsyncClient, robot_map: planner.RobotMap) -> str:
    r = await client.post("/maps", json={"occupancy_grid": robot_map.to_occupancy_grid()})
    assert r.status_code in (200, 201), r.text
    map_id: str = r.json()["map_id"]
    return map_id


def _poses(preview: dict[str, Any]) -> tuple[np.ndarray, list[int]]:
    poses = np.array([[p["x"], p["y"], p["yaw"]] for p in preview["poses"]])
    return poses, [p["direction"] for p in preview["poses"]]


async def test_a_car_reverses_into_the_bay(client: httpx.AsyncClient) -> None:
    bay, start, goal = naive_shapes.parking_bay()
    map_id = await _upload(client, bay)
    body = {
        "map_id": map_id, "start": start, "goal": goal, "footprint": RECTANGLE,
        "motion": "car_reverse", "min_turning_radius": 0.5,
        "params": {"max_velocity": 0.5, "max_acceleration": 0.5, "max_angular_velocity": 1.0},
    }  # fmt: skip
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    answer = r.json()
    poses, direction = _poses(answer["preview"])
    assert naive_shapes.motion_hits(RECTANGLE, naive_shapes.blocked_centers(bay), poses) == []
    assert -1 in direction
    assert 1 in direction
    assert naive_shapes.curvatures(poses).max() <= 2.0 + 1e-6
    assert abs(math.remainder(poses[-1, 2] - goal["yaw"], 2 * math.pi)) <= math.radians(2)
    assert answer["params"]["footprint"] == [[float(x), float(y)] for x, y in RECTANGLE[::-1]]
    assert answer["params"]["robot_radius"] == pytest.approx(0.2)
    # At most 0.5 m/s, stopped at each cusp: longer than the length at 0.5 m/s.
    assert answer["preview"]["duration_s"] > answer["preview"]["length_poses_m"] / 0.5
    again = await client.get(f"/plan/{answer['plan_id']}")
    assert again.status_code == 200, again.text
    assert again.json()["preview"]["poses"] == answer["preview"]["poses"]


async def test_a_footprint_on_depot_keeps_free(client: httpx.AsyncClient, ros: Path) -> None:
    depot = planner.read_ros_map(ros / "depot.yaml")
    map_id = await _upload(client, depot)
    start, goal = {"x": 3.0, "y": 3.0, "yaw": 0.0}, {"x": 26.0, "y": 12.0}
    body = {"map_id": map_id, "start": start, "goal": goal, "footprint": RECTANGLE}
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    poses, direction = _poses(r.json()["preview"])
    assert naive_shapes.motion_hits(RECTANGLE, naive_shapes.blocked_centers(depot), poses) == []
    assert set(direction) == {1}
    plain = await client.post("/plan", json={"map_id": map_id, "start": start, "goal": goal})
    assert all("direction" not in p for p in plain.json()["preview"]["poses"])


BAD = [
    ({"footprint": [[0, 0], [1, 1], [1, 0], [0, 1]]}, "footprint", "crosses itself"),
    ({"footprint": [[-1, 0], [0, 0], [1, 0]]}, "footprint", "degenerate"),
    ({"footprint": [[math.cos(a), math.sin(a)] for a in np.linspace(0, 6, 33)]}, "footprint", ""),
    ({"footprint": [[0.3, 0.2], [0.3, -0.2]]}, "footprint", ""),
    ({"motion": "car", "min_turning_radius": 0.0}, "min_turning_radius", ""),
    ({"motion": "car", "min_turning_radius": -1.0}, "min_turning_radius", ""),
    ({"motion": "car"}, "min_turning_radius", "min_turning_radius"),
    ({"motion": "car", "min_turning_radius": 0.5, "goal": {"x": 5.0, "y": 2.0}}, "goal", "yaw"),
    ({"motion": "tank"}, "motion", ""),
    ({"params": {"max_velocity": 0}}, "params.max_velocity", "> 0"),
]


@pytest.mark.parametrize(("extra", "field", "words"), BAD)
async def test_bad_shapes_are_422_naming_the_field(
    client: httpx.AsyncClient, extra: dict[str, Any], field: str, words: str
) -> None:
    bay, start, goal = naive_shapes.parking_bay()
    map_id = await _upload(client, bay)
    body = {"map_id": map_id, "start": start, "goal": goal, **extra}
    r = await client.post("/plan", json=body)
    assert r.status_code == 422, r.text
    assert field.split(".")[0] in r.text
    assert words in r.text


async def test_a_fleet_robot_takes_its_enclosing_circle(client: httpx.AsyncClient) -> None:
    bay, _, _ = naive_shapes.parking_bay()
    map_id = await _upload(client, bay)
    body = {"map_id": map_id, "start": {"x": 1.0, "y": 1.5}, "goal": {"x": 7.0, "y": 1.5},
            "footprint": RECTANGLE, "fleet": "shapes"}  # fmt: skip
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    params = r.json()["params"]
    assert params["robot_radius"] == pytest.approx(math.hypot(0.3, 0.2))
    assert params["footprint"] is None
    car = {**body, "motion": "car", "min_turning_radius": 0.5, "goal": {"x": 7.0, "y": 1.5,
                                                                        "yaw": 0.0}}  # fmt: skip
    r = await client.post("/plan", json=car)
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "motion"


def test_the_schemas_limits_are_the_planners() -> None:
    """``schemas`` keeps its own copies (it never imports the planner)."""
    from planner.footprint import MAX_VERTICES
    from planner.motion.search import MOTIONS
    from schemas.plans import MAX_FOOTPRINT_VERTICES, Motion

    assert MAX_FOOTPRINT_VERTICES == MAX_VERTICES
    assert typing.get_args(Motion) == MOTIONS

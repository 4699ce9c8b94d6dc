"""A footprint's search is bounded by the request's timeout: out of time it answers a ``422``
``NO_VALID_PATH`` that says so, before the timeout's ``504``."""

from __future__ import annotations

import asyncio
import time
from typing import Any

import httpx
import pytest

from service.config import Settings
from tests import naive_shapes
from tests.naive_shapes import RECTANGLE

pytestmark = pytest.mark.anyio


@pytest.fixture
def settings() -> Settings:
    return Settings(pool_size=2, request_timeout_seconds=4.0)


async def test_a_search_over_the_request_timeout_ends_in_time(client: httpx.AsyncClient) -> None:
    # Forward only, no way ends in the bay facing out: along a 96 m aisle the search takes
    # about 7 s (1.46 M nodes, warm, AMD EPYC) to find none; 24 m (0.35 M nodes) took 2.1 s
    # here but under 2 s on a faster machine, which then answered before its budget ran out.
    bay, start, goal = naive_shapes.parking_bay(length=96.0)
    for _ in range(1200):  # every kernel compiled first: no request here waits for a compile
        if (await client.get("/readyz")).json()["pool"]["warm"]:
            break
        await asyncio.sleep(0.1)
    r = await client.post("/maps", json={"occupancy_grid": bay.to_occupancy_grid()})
    assert r.status_code in (200, 201), r.text
    car: dict[str, Any] = {
        "map_id": r.json()["map_id"], "start": start, "footprint": RECTANGLE, "motion": "car",
        "min_turning_radius": 0.5,
    }  # fmt: skip
    ahead = {"x": 3.0, "y": 1.5, "yaw": 0.0}  # first a plan that compiles the kernels
    r = await client.post("/plan", json={**car, "goal": ahead})
    assert r.status_code == 201, r.text
    t0 = time.perf_counter()
    r = await client.post("/plan", json={**car, "goal": goal})
    took = time.perf_counter() - t0
    assert r.status_code == 422, r.text
    problem = r.json()
    assert "NO_VALID_PATH" in problem["detail"]
    assert "ran out of its 2 s" in problem["detail"]  # half the request's 4 s
    assert took < 4.0  # before the request's timeout

"""Heavy work against a real server (``python -m service``, over TCP): a first plan on the
largest map (4096 x 4096) analyses it on a worker thread, and the event loop keeps its turns:
``/healthz`` answers within 0.5 s throughout (the distance transforms held the GIL ~2 s)."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import numpy as np
import orjson
import pytest

from tests.service.conftest import Replica, replicas
from tests.service.test_hostile_abuse import Healthz

SIDE = 4096
"""The largest map's side (``PLANNER_MAX_MAP_CELLS``, 4096 x 4096 by default)."""

STALL_SECONDS = 0.5
"""The longest a probe may wait (issue 36's target)."""


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Replica]:
    directory = tmp_path_factory.mktemp("heavy")
    env = {"PLANNER_REQUEST_TIMEOUT_SECONDS": "300"}  # a loaded machine's analysis, whole
    with replicas("memory://", directory, 1, env, main=True) as (replica,):
        yield replica


def test_healthz_answers_while_a_first_plan_analyses_the_largest_map(server: Replica) -> None:
    blocked = np.zeros((SIDE, SIDE), dtype=bool)
    edge = (SIDE - 3000) // 2
    blocked[edge : edge + 3000, edge : edge + 3000] = True  # a block in the middle, as abuse.py
    chars = np.where(blocked, ord("@"), ord(".")).astype(np.uint8)
    body = orjson.dumps({"rows": [bytes(row).decode() for row in chars], "resolution": 0.05})
    with httpx.Client(base_url=server.url, trust_env=False, timeout=300) as c:
        r = c.post("/maps", content=body, headers={"content-type": "application/json"})
        assert r.status_code == 201, r.text[:300]
        ends = {"map_id": r.json()["map_id"], "start": [0, 0], "goal": [SIDE - 1, SIDE - 1]}
        with Healthz(server.url) as health:
            r = c.post("/plan", json=ends)
        assert r.status_code == 201, r.text[:300]
    assert not r.json()["analysis"]["cache_hit"]  # the whole map was analysed meanwhile
    assert not health.failures, health.failures
    assert health.stall <= STALL_SECONDS, health.stall

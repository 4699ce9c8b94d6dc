"""Routes through many waypoints against a real server (``python -m service``, over TCP): a
route whose legs share a wave, evicted by the next route's waves, is forgotten once (it was a
500: ``KeyError`` inside the cache's eviction, the eviction left half done)."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import numpy as np
import pytest

from tests.service.conftest import Replica, replicas

SIDE = 1024
"""A free 1024 x 1024 map at 0.05 m: a leg's wave settles up to 1/8 of it (the whole map's,
~17 MB, past that), so that 64 legs overflow a cache of 48 MB and evict the first route's
waves."""


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Replica]:
    directory = tmp_path_factory.mktemp("waypoints")
    env = {"PLANNER_CACHE_BYTES": str(48 << 20)}
    with replicas("memory://", directory, 1, env, main=True) as (replica,):
        yield replica


def test_routes_evicting_a_route_with_shared_waves_answer(server: Replica) -> None:
    with httpx.Client(base_url=server.url, trust_env=False, timeout=120) as c:
        r = c.post("/maps", json={"rows": ["." * SIDE] * SIDE, "resolution": 0.05})
        assert r.status_code == 201, r.text[:300]
        map_id = r.json()["map_id"]
        ends = {"map_id": map_id, "start": [0, 0], "goal": [SIDE - 1, SIDE - 1]}
        patrol = [[900, 100], [100, 900]] * 4  # legs to the same cell share its wave
        first = c.post("/plan", json={**ends, "waypoints": patrol})
        assert first.status_code == 201, first.text[:300]
        spread = np.random.default_rng(36).integers(0, SIDE, (64, 2)).tolist()
        for _ in range(2):
            r = c.post("/plan", json={**ends, "waypoints": spread})
            assert r.status_code == 201, r.text[:300]
        metrics = c.get("/metrics").text
        evictions = next(
            float(line.split()[1])
            for line in metrics.splitlines()
            if line.startswith("planner_cache_evictions_total")
        )
        assert evictions > 0  # the first route's waves went
        plan_id = first.json()["plan_id"]
        r = c.post(f"/plan/{plan_id}/step", json={})  # rebuilt over new waves
        assert r.status_code == 200, r.text[:300]
        assert c.get(f"/plan/{plan_id}").status_code == 200
        log = server.log.read_text()
        assert "Traceback" not in log, log[-3000:]

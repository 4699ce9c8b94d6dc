"""``GET /metrics``: Prometheus text that parses, requests by route template and status, the
pool's busy workers and queue, the cache, and exact counts of maps and live plans."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import pytest
from fastapi import FastAPI
from prometheus_client.parser import text_string_to_metric_families
from prometheus_client.samples import Sample

import planner
from service.config import Settings
from service.main import create_app
from service.ops.metrics import UNMATCHED, Metrics
from service.stores import RedisStore
from tests.service.conftest import RedisServer, random_map, running

pytestmark = pytest.mark.anyio

GRID = random_map(16, 16, 0.15, seed=5).tolist()
STEP = "/plan/{plan_id}/step"


async def scrape(client: httpx.AsyncClient) -> dict[str, list[Sample]]:
    """Every sample of ``/metrics`` by family name, parsed by prometheus_client's parser."""
    r = await client.get("/metrics")
    assert r.status_code == 200
    assert r.headers["content-type"].startswith("text/plain")
    families = list(text_string_to_metric_families(r.text))
    names = [f.name for f in families]
    assert len(names) == len(set(names)), "a family twice"
    return {f.name: list(f.samples) for f in families}


def value(samples: list[Sample], name: str, **labels: str) -> float:
    found = [s.value for s in samples if s.name == name and s.labels == labels]
    assert len(found) == 1, (name, labels, found)
    return found[0]


def templates(app: FastAPI) -> set[str]:
    """The app's route templates: its API's paths and its own routes (docs, static files)."""
    own = {path for route in app.routes if isinstance(path := getattr(route, "path", None), str)}
    return set(app.openapi()["paths"]) | own


async def test_requests_are_counted_by_route_template_and_status(
    app: FastAPI, client: httpx.AsyncClient
) -> None:
    r = await client.post("/maps", json={"grid": GRID, "start": [0, 0], "goal": [15, 15]})
    plan_id = r.json()["plan"]["plan_id"]
    for seq in range(3):
        assert (await client.post(f"/plan/{plan_id}/step", json={"seq": seq})).status_code == 200
    assert (await client.post(f"/plan/{plan_id}/step", json={"seq": 9})).status_code == 409
    assert (await client.post("/plan/0123abcd/step", json={})).status_code == 404
    bad = await client.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": "x"})
    assert bad.status_code == 422
    assert (await client.get(f"/no/such/{plan_id}")).status_code == 404
    assert (await client.get(f"/plan/{plan_id}")).status_code == 200

    samples = await scrape(client)
    requests = samples["planner_http_requests"]
    step = {"method": "POST", "route": STEP}
    assert value(requests, "planner_http_requests_total", **step, status="200") == 3
    assert value(requests, "planner_http_requests_total", **step, status="409") == 1
    assert value(requests, "planner_http_requests_total", **step, status="404") == 1
    assert value(requests, "planner_http_requests_total", **step, status="422") == 1
    unmatched = {"method": "GET", "route": UNMATCHED, "status": "404"}
    assert value(requests, "planner_http_requests_total", **unmatched) == 1
    get_plan = {"method": "GET", "route": "/plan/{plan_id}", "status": "200"}
    assert value(requests, "planner_http_requests_total", **get_plan) == 1

    durations = samples["planner_http_request_duration_seconds"]
    counted = [s for s in requests if s.name == "planner_http_requests_total"]
    assert len(counted) >= 7
    for sample in counted:
        count = value(durations, "planner_http_request_duration_seconds_count", **sample.labels)
        inf = value(
            durations, "planner_http_request_duration_seconds_bucket", **sample.labels, le="+Inf"
        )
        assert count == inf == sample.value
    # Only route templates are label values: no plan id, no unknown path.
    routes = {s.labels["route"] for family in samples.values() for s in family if s.labels}
    assert routes <= templates(app) | {UNMATCHED}
    assert not any(plan_id in str(s.labels) for f in samples.values() for s in f)

    assert value(samples["planner_cache_misses"], "planner_cache_misses_total") >= 1
    assert value(samples["planner_cache_hits"], "planner_cache_hits_total") >= 1
    assert value(samples["planner_cache_bytes"], "planner_cache_bytes") > 0


async def test_maps_and_live_plans_are_counted_exactly(client: httpx.AsyncClient) -> None:
    samples = await scrape(client)
    assert value(samples["planner_maps"], "planner_maps") == 0
    assert value(samples["planner_plans"], "planner_plans") == 0
    plans = []
    for goal in ([15, 15], [0, 15], [15, 0]):
        r = await client.post("/maps", json={"grid": GRID, "start": [0, 0], "goal": goal})
        plans.append(r.json()["plan"]["plan_id"])
    await client.post("/maps", json={"grid": [[0, 0], [0, 1]]})
    assert (await client.delete(f"/plan/{plans[1]}")).status_code == 204
    samples = await scrape(client)
    assert value(samples["planner_maps"], "planner_maps") == 2
    assert value(samples["planner_plans"], "planner_plans") == 2
    assert value(samples["planner_store_up"], "planner_store_up") == 1


@pytest.fixture
async def one_worker() -> AsyncIterator[httpx.AsyncClient]:
    app = create_app(Settings(pool_size=1))
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            yield c


async def test_pool_gauges_follow_four_big_uploads_on_one_worker(
    one_worker: httpx.AsyncClient,
) -> None:
    client = one_worker
    idle = await scrape(client)
    assert value(idle["planner_pool_workers"], "planner_pool_workers") == 1
    bodies = [
        {"grid": random_map(512, 512, 0.2, seed).tolist(), "start": [0, 0], "goal": [511, 511]}
        for seed in range(4)
    ]
    uploads = [asyncio.ensure_future(client.post("/maps", json=body)) for body in bodies]
    seen: list[tuple[float, float]] = []
    while not all(u.done() for u in uploads):
        samples = await scrape(client)  # answers while the pool is busy
        busy = value(samples["planner_pool_busy_workers"], "planner_pool_busy_workers")
        queue = value(samples["planner_pool_queue_depth"], "planner_pool_queue_depth")
        seen.append((busy, queue))
        await asyncio.sleep(0.005)
    assert [u.result().status_code for u in uploads] == [201] * 4
    assert max(b for b, _ in seen) == 1
    assert max(q for _, q in seen) >= 1
    after = await scrape(client)
    assert value(after["planner_pool_busy_workers"], "planner_pool_busy_workers") == 0
    assert value(after["planner_pool_queue_depth"], "planner_pool_queue_depth") == 0


async def test_the_redis_store_counts_maps_and_live_plans(redis_server: RedisServer) -> None:
    store = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        grid = planner.grid_map(random_map(4, 4, 0.0, seed=0))
        await store.put_map("a", grid)
        await store.put_map("b", grid)
        for plan_id in ("p", "q", "r"):
            await store.put_plan(plan_id, {"n": 1}, append=[(0, 0)])
        await store.delete_plan("q")
        assert await store.counts() == (2, 2)
    finally:
        await store.close()


async def test_metrics_answer_and_say_so_while_redis_is_down(tmp_path: Path) -> None:
    server = RedisServer(tmp_path / "redis")
    server.start()
    app = create_app(Settings(pool_size=1, store_url=server.url))
    try:
        async with running(app):
            transport = httpx.ASGITransport(app=app)
            async with httpx.AsyncClient(transport=transport, base_url="http://s") as client:
                assert value((await scrape(client))["planner_store_up"], "planner_store_up") == 1
                server.stop()
                samples = await scrape(client)
                assert value(samples["planner_store_up"], "planner_store_up") == 0
                assert "planner_plans" not in samples
    finally:
        server.stop()


async def test_durations_fall_in_the_buckets_prometheus_would_put_them_in() -> None:
    """A request as long as a bucket's bound counts in it (``le`` is inclusive), one longer
    than every bound only in ``+Inf``; buckets are cumulative, ``_count`` and the counter are
    the requests, ``_sum`` their seconds."""
    metrics = Metrics()
    for seconds in (0.0, 0.001, 0.0011, 2.5, 60.0, 61.0):
        metrics.observe("POST", STEP, 200, seconds)
    metrics.observe("GET", STEP, 404, 0.3)
    samples = {
        f.name: list(f.samples)
        for f in text_string_to_metric_families((await metrics.render()).decode())
    }
    labels = {"method": "POST", "route": STEP, "status": "200"}
    durations = samples["planner_http_request_duration_seconds"]
    bucket = "planner_http_request_duration_seconds_bucket"
    expected = {"0.001": 2, "0.0025": 3, "1.0": 3, "2.5": 4, "30.0": 4, "60.0": 5, "+Inf": 6}
    for le, count in expected.items():
        assert value(durations, bucket, **labels, le=le) == count
    assert value(durations, "planner_http_request_duration_seconds_count", **labels) == 6
    assert value(durations, "planner_http_request_duration_seconds_sum", **labels) == (
        pytest.approx(0.001 + 0.0011 + 2.5 + 60.0 + 61.0)
    )
    assert value(samples["planner_http_requests"], "planner_http_requests_total", **labels) == 6
    other = {"method": "GET", "route": STEP, "status": "404"}
    assert value(durations, bucket, **other, le="0.25") == 0
    assert value(durations, bucket, **other, le="0.5") == 1

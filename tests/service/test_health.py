"""Liveness and readiness: ``/healthz`` answers 200 whatever the store does and shows no
address; ``/readyz`` answers 503 while Redis is down or the pool is cold, and 200 again when Redis
is back, without a restart. The pool's size follows the cgroup's CPU quota."""

from __future__ import annotations

import os
import time
from pathlib import Path

import anyio
import httpx
import pytest
from fastapi import FastAPI

from service.cgroup import available_cpus, parse_cpu_max
from service.config import Settings
from service.work.engine import Engine
from tests.service.conftest import RedisServer, replicas


@pytest.mark.parametrize(
    ("text", "cpus"),
    [
        ("max 100000\n", None),
        ("max\n", None),
        ("200000 100000\n", 2.0),
        ("150000 100000\n", 1.5),
        ("50000 100000\n", 0.5),
        ("400000 200000", 2.0),
        ("", None),
        ("garbage here", None),
        ("-1 100000", None),
    ],
)
def test_cpu_max_is_parsed(text: str, cpus: float | None) -> None:
    assert parse_cpu_max(text) == cpus


def test_the_pool_follows_the_cgroup_quota(tmp_path: Path) -> None:
    here = len(os.sched_getaffinity(0))
    cpu_max = tmp_path / "cpu.max"
    cpu_max.write_text("max 100000\n")
    assert available_cpus(cpu_max) == here
    cpu_max.write_text("50000 100000\n")  # half a CPU: one worker
    assert available_cpus(cpu_max) == 1
    cpu_max.write_text("150000 100000\n")  # 1.5 CPUs: two workers, when there are two
    assert available_cpus(cpu_max) == min(here, 2)
    cpu_max.write_text(f"{(here + 8) * 100000} 100000\n")  # a quota above the CPUs
    assert available_cpus(cpu_max) == here
    assert available_cpus(tmp_path / "missing") == here  # no cgroup v2


def test_the_default_pool_size_is_the_available_cpus(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("PLANNER_POOL_SIZE", raising=False)
    assert Settings().pool_size == available_cpus()


@pytest.mark.anyio
async def test_liveness_asks_nothing_of_the_store_and_readiness_does(
    app: FastAPI, client: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    engine: Engine = app.state.engine

    async def down() -> str:
        return "store unavailable: redis at 10.0.0.7:6379 refused the connection; retry later"

    async def never() -> str:
        raise AssertionError("/healthz asked the store")

    monkeypatch.setattr(engine.store, "check", down)
    r = await client.get("/readyz")
    assert r.status_code == 503
    assert r.json()["status"] == "unavailable"
    assert r.json()["store"]["up"] is False
    monkeypatch.setattr(engine.store, "check", never)
    r = await client.get("/healthz")
    assert r.status_code == 200
    assert "10.0.0.7" not in r.text
    assert r.json()["status"] == "ok"


@pytest.mark.anyio
async def test_readiness_waits_for_the_warm_up(app: FastAPI, client: httpx.AsyncClient) -> None:
    engine: Engine = app.state.engine
    engine.pool.serving = False
    r = await client.get("/readyz")
    assert r.status_code == 503
    assert (await client.get("/healthz")).status_code == 200
    engine.pool.serving = True
    engine.pool.warm = False  # the rest still compiling in the background: ready, and says so
    r = await client.get("/readyz")
    assert r.status_code == 200
    assert r.json()["pool"]["warm"] is False
    engine.pool.warm = True
    assert (await client.get("/readyz")).status_code == 200


@pytest.mark.anyio
@pytest.mark.parametrize("settings", [Settings(pool_size=2, warmup_wait_seconds=0)])
async def test_past_the_warm_up_wait_it_serves_while_the_rest_compiles(
    app: FastAPI, client: httpx.AsyncClient
) -> None:
    """With no wait the service is ready at once, says the kernels are not all compiled, serves
    a plan and its steps meanwhile (off the event loop), then says they are."""
    engine: Engine = app.state.engine
    r = await client.get("/readyz")
    assert r.status_code == 200
    rows = ["......", "......", "..@@..", "......", "......"]
    created = await client.post("/maps", json={"rows": rows, "start": [0, 0], "goal": [4, 5]})
    assert created.status_code == 201, created.text
    plan_id = created.json()["plan"]["plan_id"]
    for seq in range(3):
        step = await client.post(
            f"/plan/{plan_id}/step", json={"seq": seq, "dynamic_obstacles": []}
        )
        assert step.status_code == 200, step.text
    deadline = time.monotonic() + 600
    while not engine.pool.warm:
        assert time.monotonic() < deadline, "the background warm-up never ended"
        await anyio.sleep(0.05)
    assert (await client.get("/readyz")).json()["pool"]["warm"] is True


def test_redis_killed_then_back_on_its_port(tmp_path: Path) -> None:
    server = RedisServer(tmp_path / "redis")
    server.start()
    try:
        with (
            replicas(server.url, tmp_path, 1) as (replica,),
            httpx.Client(base_url=replica.url, trust_env=False, timeout=30) as client,
        ):
            assert client.get("/readyz").status_code == 200
            server.stop()
            killed = time.monotonic()
            while client.get("/readyz").status_code != 503:
                assert time.monotonic() - killed < 8, "/readyz still 200 8 s after Redis died"
                assert client.get("/healthz").status_code == 200
                time.sleep(0.1)
            for _ in range(10):  # and liveness stays up while Redis is down
                health = client.get("/healthz")
                assert health.status_code == 200
                assert str(server.port) not in health.text
                time.sleep(0.1)
            server.start()  # the same port
            back = time.monotonic()
            while (ready := client.get("/readyz")).status_code != 200:
                assert time.monotonic() - back < 12, f"/readyz not 200 12 s on: {ready.text}"
                time.sleep(0.1)
            assert ready.json()["store"]["up"] is True
            assert replica.process.poll() is None  # no restart
    finally:
        server.stop()

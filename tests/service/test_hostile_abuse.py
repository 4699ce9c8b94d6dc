"""Abuse against a real server (``python -m service``, over TCP): requests and connections
whose size would become time on the event loop or memory in the process.

A YAML alias bomb is refused at once; a step's circles cost what the map's cells cost, whatever
their radius; a body of a million unknown keys is refused before validation; a JSON grid over
its limit is refused unparsed; thousands of idle connections leave ``/healthz`` answering; a
step stopped by the request timeout does not move the robot. Meanwhile ``/healthz``, polled every
50 ms on fresh connections, keeps answering.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import httpx
import pytest

from tests.planner.test_robot_maps import alias_bomb
from tests.service.conftest import Replica, replicas

LIMITS = {
    "PLANNER_POOL_SIZE": "2",
    "PLANNER_BODY_TIMEOUT_SECONDS": "3",
    "PLANNER_REQUEST_TIMEOUT_SECONDS": "3",
}
"""The defaults but for the timeouts, so that a stopped request shows in little time."""


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Replica]:
    directory = tmp_path_factory.mktemp("abuse")
    with replicas("memory://", directory, 1, LIMITS, main=True) as (replica,):
        yield replica


@pytest.fixture(scope="module")
def client(server: Replica) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=server.url, trust_env=False, timeout=30) as c:
        yield c


class Healthz(threading.Thread):
    """``/healthz`` every 50 ms, each on a new connection, while a ``with`` block runs: the
    slowest answer (``stall``, seconds) and the answers that were not 200 (``failures``)."""

    def __init__(self, url: str) -> None:
        super().__init__(daemon=True)
        self.url = url
        self.stall = 0.0
        self.failures: list[str] = []
        self._done = threading.Event()

    def run(self) -> None:
        limits = httpx.Limits(max_keepalive_connections=0)
        with httpx.Client(base_url=self.url, trust_env=False, timeout=30, limits=limits) as c:
            while not self._done.is_set():
                t0 = time.monotonic()
                try:
                    status = str(c.get("/healthz").status_code)
                except httpx.HTTPError as exc:
                    status = type(exc).__name__
                self.stall = max(self.stall, time.monotonic() - t0)
                if status != "200":
                    self.failures.append(status)
                self._done.wait(0.05)

    def __enter__(self) -> Healthz:
        self.start()
        time.sleep(0.1)
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        self.join(timeout=60)


def test_a_yaml_alias_bomb_is_refused_at_once(client: httpx.Client, server: Replica) -> None:
    bomb = alias_bomb(9).encode()
    assert len(bomb) < 600
    files = {
        "yaml": ("m.yaml", bomb, "application/yaml"),
        "image": ("m.pgm", b"P5 1 1 255 \0", "image/x-portable-graymap"),
    }
    with Healthz(server.url) as health:
        t0 = time.monotonic()
        r = client.post("/maps", files=files, timeout=10)
        took = time.monotonic() - t0
    assert r.status_code == 422, r.text[:300]
    assert "aliases are refused" in r.json()["detail"]
    assert r.json()["field"] == "yaml"
    assert took < 2, took
    assert health.stall < 1, health.stall
    assert not health.failures, health.failures

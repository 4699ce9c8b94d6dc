"""Abuse against a real server (``python -m service``, over TCP): requests and connections
whose size would become time on the event loop or memory in the process.

A YAML alias bomb is refused at once; a step's circles cost what the map's rows cost, whatever
their radius; a step stopped by the request timeout does not move the robot; a body of a
million unknown keys is refused before validation; a JSON grid over its limit is refused
unparsed; 4,100 idle connections leave every route answering; a megabyte header is cut at
PLANNER_MAX_HEADER_BYTES; requests beyond PLANNER_MAX_REQUESTS get 503 but the probes do not;
an idle keep-alive connection is closed; trickled headers are cut by nginx in front (uvicorn
cannot). Meanwhile ``/healthz``, polled every 50 ms on fresh connections, keeps answering.
"""

from __future__ import annotations

import contextlib
import resource
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from service.__main__ import FILES_BESIDE_CONNECTIONS, open_file_limit
from tests.planner.test_robot_maps import alias_bomb
from tests.service.conftest import Replica, replicas
from tests.service.test_nginx import nginx_in_front  # noqa: F401 - a fixture

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


def _open_map(client: httpx.Client, side: int, resolution: float) -> str:
    """A free ``side`` x ``side`` map at ``resolution``, and a plan across it: its id."""
    body = {
        "rows": ["." * side] * side,
        "resolution": resolution,
        "start": [side // 2, 0],
        "goal": [side // 2, side - 1],
        "preset": "shortest",
    }
    r = client.post("/maps", json=body)
    assert r.status_code in (200, 201), r.text[:300]
    return str(r.json()["plan"]["plan_id"])


@pytest.mark.parametrize(("count", "radius"), [(200, 1e6), (2000, 5.0)])
def test_circles_cost_the_map_not_their_radius(
    client: httpx.Client, server: Replica, count: int, radius: float
) -> None:
    """200 circles of 10**6 m, or 2,000 of 5 m, over a 1000 x 1000 map (50 m a side): a
    step answers, and /healthz with it (a box of cells per circle took 6.6 s and 2.0 s, on
    the event loop)."""
    plan_id = _open_map(client, 1000, 0.05)
    spots = [(i * 7919 % 5000 / 100, i * 104729 % 5000 / 100) for i in range(count)]
    circles = [{"x": x, "y": y, "radius": radius} for x, y in spots]
    with Healthz(server.url) as health:
        t0 = time.monotonic()
        r = client.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": circles})
        took = time.monotonic() - t0
    assert r.status_code == 200, r.text[:300]
    assert r.json()["move"] == "WAIT"  # the robot is under a circle
    assert took < 2.5, took
    assert health.stall < 1, health.stall
    assert not health.failures, health.failures


@pytest.fixture(scope="module")
def hurried(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Replica]:
    """A server with a 1 s request timeout, and room for 200,000 circles in a step."""
    env = {
        "PLANNER_POOL_SIZE": "2",
        "PLANNER_REQUEST_TIMEOUT_SECONDS": "1",
        "PLANNER_MAX_DYNAMIC_OBSTACLES": "200000",
        "PLANNER_MAX_STEP_BODY_BYTES": str(32 << 20),
    }
    with replicas("memory://", tmp_path_factory.mktemp("hurried"), 1, env, main=True) as (one,):
        yield one


def test_a_step_stopped_by_the_timeout_does_not_move_the_robot(hurried: Replica) -> None:
    """200,000 circles that each span every row of the map (600) but cover only a sliver of its
    right edge: seconds of rasterising, well over the request timeout however fast the machine
    (100,000 on 300 rows took under its second on a fast one), stopped there (504); the robot,
    free to move east, has not moved; the same seq, retried without them, moves it."""
    with httpx.Client(base_url=hurried.url, trust_env=False, timeout=60) as client:
        plan_id = _open_map(client, 600, 0.025)  # 15 m a side
        far = 1e5
        sliver = {"x": 15.0 + far - 0.03, "y": 7.5, "radius": far}
        t0 = time.monotonic()
        r = client.post(
            f"/plan/{plan_id}/step", json={"seq": 0, "dynamic_obstacles": [sliver] * 200_000}
        )
        took = time.monotonic() - t0
        assert r.status_code == 504, r.text[:300]
        assert "PLANNER_REQUEST_TIMEOUT_SECONDS" in r.json()["detail"]
        assert took < 5, took
        plan = client.get(f"/plan/{plan_id}").json()
        assert plan["position"] == [300, 0]
        assert plan["trajectory"] == [[300, 0]]
        r = client.post(f"/plan/{plan_id}/step", json={"seq": 0, "dynamic_obstacles": [sliver]})
        assert r.status_code == 200, r.text[:300]
        assert r.json()["move"] == "E"


def _unknown_keys(count: int) -> bytes:
    return b"{" + b",".join(b'"k%d":1' % i for i in range(count)) + b"}"


def test_a_body_of_a_million_unknown_keys_is_refused_unparsed(
    client: httpx.Client, server: Replica
) -> None:
    """An 11 MB body of a million keys to /plan (13.5 s and 1.3 GB of validation errors
    before): a plan's body is small (413 by its size); within that size, 95,000 keys are
    refused from the bytes (422 naming the count), and a step's circles with unknown keys
    too."""
    huge = _unknown_keys(1_000_000)
    assert len(huge) > 11_000_000
    json = {"content-type": "application/json"}
    with Healthz(server.url) as health:
        r = client.post("/plan", content=huge, headers=json)
        assert r.status_code == 413, r.text[:300]
        assert "PLANNER_MAX_STEP_BODY_BYTES" in r.json()["detail"]
        r = client.post("/plan", content=_unknown_keys(95_000), headers=json)
        assert r.status_code == 422, r.text[:300]
        assert "holds 95000 object keys; the limit is 31024" in r.json()["detail"]
        plan_id = _open_map(client, 20, 0.1)
        circle = b'{"x":1,"y":1,"radius":1,"a":1,"b":2,"c":3,"d":4}'
        step = b'{"dynamic_obstacles":[' + b",".join([circle] * 20_000) + b"]}"
        r = client.post(f"/plan/{plan_id}/step", content=step, headers=json)
        assert r.status_code == 422, r.text[:300]
        assert "holds 140001 object keys" in r.json()["detail"]
    assert health.stall < 1, health.stall
    assert not health.failures, health.failures


def _idle(server: Replica, count: int) -> list[socket.socket]:
    return [socket.create_connection(("127.0.0.1", server.port), timeout=10) for _ in range(count)]


def test_healthz_and_the_api_answer_beside_4100_idle_connections(
    client: httpx.Client, server: Replica
) -> None:
    """4,100 connections that send nothing (uvicorn's limit was 4,096 connections: every
    route, /healthz too, answered 503)."""
    sockets = _idle(server, 4100)
    try:
        with Healthz(server.url) as health:
            fresh = httpx.Limits(max_keepalive_connections=0)
            with httpx.Client(base_url=server.url, trust_env=False, limits=fresh) as other:
                assert other.get("/readyz").status_code == 200
                assert other.get("/maps/unknown").status_code == 404
                plan_id = _open_map(other, 20, 0.1)
                assert other.post(f"/plan/{plan_id}/step", json={}).status_code == 200
        assert health.stall < 1, health.stall
        assert not health.failures, health.failures
    finally:
        for sock in sockets:
            sock.close()


def test_a_request_head_over_max_header_bytes_is_refused(server: Replica) -> None:
    """A header of megabytes (httptools kept every byte: 90 MB on one connection) is cut at
    PLANNER_MAX_HEADER_BYTES (16 KiB): 400, and the connection closed."""
    before = _rss_mib(server)
    with socket.create_connection(("127.0.0.1", server.port), timeout=10) as sock:
        sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\nX-Big: ")
        answer = b""
        with contextlib.suppress(OSError):  # the server may close while we still send
            for _ in range(64):
                sock.sendall(b"a" * (1 << 20))
        with contextlib.suppress(OSError):
            while chunk := sock.recv(4096):
                answer += chunk
    assert answer.startswith(b"HTTP/1.1 400"), answer[:100]
    assert _rss_mib(server) - before < 20


def _rss_mib(server: Replica) -> float:
    status = Path(f"/proc/{server.process.pid}/status").read_text()
    return int(status.split("VmRSS:")[1].split()[0]) / 1024


@pytest.fixture(scope="module")
def guarded(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Replica]:
    """A server that takes 8 requests at once, closes idle connections after 1 s, and takes
    JSON maps of 10,000 cells at most."""
    env = {
        "PLANNER_MAX_REQUESTS": "8",
        "PLANNER_KEEP_ALIVE_SECONDS": "1",
        "PLANNER_MAX_JSON_MAP_CELLS": "10000",
    }
    with replicas("memory://", tmp_path_factory.mktemp("guarded"), 1, env, main=True) as (one,):
        yield one


def test_requests_beyond_max_requests_get_503_but_probes_answer(guarded: Replica) -> None:
    """8 requests in progress (bodies on their way): a 9th is 503 BUSY with Retry-After;
    /healthz and /readyz still answer; once those end, requests are served again."""
    pending = _idle(guarded, 8)
    try:
        for sock in pending:
            sock.sendall(
                b"POST /plan HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                b"Content-Length: 1000\r\n\r\n{"
            )
        time.sleep(0.5)
        with httpx.Client(base_url=guarded.url, trust_env=False, timeout=10) as c:
            r = c.get("/maps/unknown")
            assert r.status_code == 503, r.text
            assert r.json()["code"] == "BUSY"
            assert "PLANNER_MAX_REQUESTS is 8" in r.json()["detail"]
            assert r.headers["retry-after"] == "1"
            assert c.get("/healthz").status_code == 200
            assert c.get("/readyz").status_code == 200
    finally:
        for sock in pending:
            sock.close()
    time.sleep(0.5)
    with httpx.Client(base_url=guarded.url, trust_env=False, timeout=10) as c:
        assert c.get("/maps/unknown").status_code == 404


def test_an_idle_keep_alive_connection_is_closed_after_keep_alive_seconds(
    guarded: Replica,
) -> None:
    with socket.create_connection(("127.0.0.1", guarded.port), timeout=10) as sock:
        sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
        assert sock.recv(4096).startswith(b"HTTP/1.1 200")
        t0 = time.monotonic()
        while sock.recv(4096):  # the rest of the answer, then the end: closed by the server
            pass
        assert 0.5 < time.monotonic() - t0 < 4


def _cut(sock: socket.socket) -> bool:
    """One more header line on its way; whether the other end has answered or closed."""
    try:
        sock.sendall(b"X-Slow: 1\r\n")
        sock.recv(4096)  # an answer (408) or the end: either way, cut
    except BlockingIOError:
        return False
    except OSError:
        pass
    return True


def test_trickled_headers_are_cut_by_nginx_in_front(
    nginx_in_front: tuple[str, list[Any]],  # noqa: F811 - the fixture imported
) -> None:
    """Slowloris: 20 connections each sending a header line a second. uvicorn has no timeout
    for a request's head (benchmarks/abuse.py measures them held open); docker/nginx.conf's
    client_header_timeout (10 s) closes every one."""
    url, _ = nginx_in_front
    port = int(url.rsplit(":", 1)[1])
    sockets = [socket.create_connection(("127.0.0.1", port), timeout=30) for _ in range(20)]
    closed: dict[int, float] = {}
    t0 = time.monotonic()
    try:
        for sock in sockets:
            sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
            sock.setblocking(False)
        while len(closed) < len(sockets) and time.monotonic() - t0 < 20:
            for i, sock in enumerate(sockets):
                if i not in closed and _cut(sock):
                    closed[i] = time.monotonic() - t0
            time.sleep(1)
    finally:
        for sock in sockets:
            sock.close()
    assert len(closed) == len(sockets), f"{len(closed)} of 20 closed in 20 s"
    assert max(closed.values()) < 14, closed


def test_a_json_grid_over_its_limit_is_refused_unparsed(
    client: httpx.Client, server: Replica
) -> None:
    """A 30 MB `grid` (3800 x 3800) held the event loop 3.3 s while it was parsed: over
    PLANNER_MAX_JSON_MAP_CELLS (2 M cells) it is a 413 from its bytes, naming the encodings
    that carry a large map cheaply."""
    body = b'{"grid": [' + b",".join([b"[" + b"0," * 3799 + b"1]"] * 3800) + b"]}"
    assert len(body) > 28_000_000
    with Healthz(server.url) as health:
        r = client.post("/maps", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 413, r.text[:300]
    detail = r.json()["detail"]
    assert "PLANNER_MAX_JSON_MAP_CELLS is 2097152" in detail
    assert "`rows`" in detail
    assert "image with its YAML" in detail
    assert health.stall < 1, health.stall
    assert not health.failures, health.failures


def test_json_map_cells_are_counted_exactly_and_rows_are_not_limited(guarded: Replica) -> None:
    with httpx.Client(base_url=guarded.url, trust_env=False, timeout=30) as c:
        r = c.post("/maps", json={"grid": [[0] * 100] * 101})  # within the bytes' slack
        assert r.status_code == 413, r.text[:300]
        assert r.json()["field"] == "grid"
        assert "a `grid` or `occupancy_grid` of 10100 cells" in r.json()["detail"]
        info = {"width": 101, "height": 100, "resolution": 0.05}
        message = {"info": info, "data": [0] * 10100}
        r = c.post("/maps", json={"occupancy_grid": message})
        assert r.status_code == 413, r.text[:300]
        assert r.json()["field"] == "occupancy_grid"
        assert c.post("/maps", json={"grid": [[0] * 100] * 100}).status_code == 201
        assert c.post("/maps", json={"rows": ["." * 200] * 200}).status_code == 201


def test_the_open_file_limit_is_raised_to_hold_the_connections() -> None:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    top = hard if hard != resource.RLIM_INFINITY else soft + 4096
    try:
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(soft, top - 1), hard))
        wanted = top - FILES_BESIDE_CONNECTIONS
        assert open_file_limit(wanted) == (top, top)
        assert resource.getrlimit(resource.RLIMIT_NOFILE)[0] == top
        if hard != resource.RLIM_INFINITY:  # short of it: said, not raised past the hard limit
            assert open_file_limit(hard) == (hard, hard + FILES_BESIDE_CONNECTIONS)
    finally:
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))

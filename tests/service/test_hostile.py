"""Hostile clients against a real server: uvicorn in a process of its own, over TCP.

Every hostile request gets a small 4xx (never a 5xx, never internals); a body too slow gets 408
and its connection closed; an aborted upload is one line of log; unknown ids leave no memory
behind (an RSS bound); a DELETE racing a step leaves the plan deleted, 40 times on each store;
``/healthz`` answers quickly while a long simulation runs; a replica killed while holding a
plan's lock frees it within ~2 s.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import redis

from tests.service.conftest import RedisServer, Replica, replicas
from tests.service.test_hardening import ROWS, serpentine

LIMITS = {
    "PLANNER_POOL_SIZE": "2",
    "PLANNER_BODY_TIMEOUT_SECONDS": "3",
    "PLANNER_REQUEST_TIMEOUT_SECONDS": "3",
    "PLANNER_MAX_BODY_BYTES": str(4 << 20),
    "PLANNER_MAX_STEP_BODY_BYTES": "65536",
    "PLANNER_MAX_MAP_CELLS": str(1 << 20),
    "PLANNER_MAP_STORE_BYTES": str(4 << 20),
    "PLANNER_MAX_SIMULATION_STEPS": "500000",
}
"""Small limits, so that the tests reach them with small bodies and in little time."""

INTERNALS = ("Traceback", "127.0.0.1", "/work/", "site-packages", "Error(", "redis://")


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Replica]:
    directory = tmp_path_factory.mktemp("hostile")
    with replicas("memory://", directory, 1, LIMITS) as (replica,):
        yield replica


@pytest.fixture(scope="module")
def client(server: Replica) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=server.url, trust_env=False, timeout=30) as c:
        yield c


def _plan(client: httpx.Client) -> tuple[str, str, list[list[int]]]:
    r = client.post("/maps", json={"rows": ROWS, "start": [0, 0], "goal": [4, 5]})
    assert r.status_code in (200, 201), r.text
    plan = r.json()["plan"]
    return r.json()["map_id"], plan["plan_id"], plan["preview"]["path"]


def _deep(depth: int) -> bytes:
    return b'{"start": ' + b"[" * depth + b"]" * depth + b"}"


def _hostile(map_id: str, plan_id: str) -> list[tuple[str, str, Any, dict[str, str]]]:
    """(method, url, JSON body or raw bytes, headers): 40 and more requests no client should
    send."""
    posts = ["/maps", "/plan", f"/plan/{plan_id}/step", f"/maps/{map_id}/simulate"]
    raw = {"content-type": "application/json"}
    cases: list[tuple[str, str, Any, dict[str, str]]] = []
    for url in posts:  # deep nesting on every POST route
        cases += [("POST", url, _deep(100), raw), ("POST", url, _deep(100_000), raw)]
        cases += [("POST", url, b"[" * 3000, raw)]  # deep and unclosed
    step, sim = f"/plan/{plan_id}/step", f"/maps/{map_id}/simulate"
    plan = {"map_id": map_id, "start": [0, 0], "goal": [4, 5]}
    cases += [  # wrong types
        ("POST", "/maps", {"grid": "0101"}, {}),
        ("POST", "/maps", {"rows": 12}, {}),
        ("POST", "/maps", {"grid": [[0, None]]}, {}),
        ("POST", "/plan", {**plan, "start": "a"}, {}),
        ("POST", "/plan", {**plan, "goal": {}}, {}),
        ("POST", "/plan", {**plan, "preset": 5}, {}),
        ("POST", "/plan", {**plan, "params": {"alpha": "x"}}, {}),
        ("POST", "/plan", {**plan, "params": {"alpha": {"b": [[[1]]]}}}, {}),
        ("POST", step, {"dynamic_obstacles": "x"}, {}),
        ("POST", step, {"seq": "x"}, {}),
        ("POST", step, {"position": [True, False]}, {}),
        ("POST", sim, {"start": [0, 0], "goal": [4, 5], "dynamic_count": -1}, {}),
        ("POST", sim, {"start": [0, 0], "goal": [4, 5], "seed": -1}, {}),
        ("POST", "/plan", None, {}),
        ("POST", "/plan", b"[]", raw),
        ("POST", "/plan", b'"text"', raw),
        ("POST", "/plan", b"1e999999", raw),
        ("POST", "/plan", b"\xff\xfe\x00garbage", raw),
        ("POST", "/plan", b"{}" + b"\x00" * 100, raw),
    ]
    cases += [  # huge values
        ("POST", "/plan", {**plan, "start": [10**30, 0]}, {}),
        ("POST", "/maps", {"grid": [[0, 10**20]]}, {}),
        ("POST", step, {"seq": 2**70}, {}),
        ("POST", sim, {"start": [0, 0], "goal": [4, 5], "max_steps": 10**18}, {}),
        ("POST", sim, {"start": [0, 0], "goal": [4, 5], "dynamic_count": 10**9}, {}),
        ("POST", "/plan", {**plan, "map_id": "m" * 1_000_000}, {}),
        ("POST", "/plan", {**plan, "p" * 200_000: 1}, {}),
        ("POST", step, {"dynamic_obstacles": [[1, 1]] * 20_000}, {}),  # over the step limit
        ("POST", "/maps", {"rows": ["." * 2000] * 2000}, {}),  # over the body limit
    ]
    cases += [  # bad content types
        ("POST", "/plan", b"map_id=x", {"content-type": "application/x-www-form-urlencoded"}),
        ("POST", "/plan", b"<plan/>", {"content-type": "application/xml"}),
        ("POST", "/plan", b"--x\r\n\r\n--x--", {"content-type": "multipart/form-data; boundary=x"}),
        ("POST", "/maps", b"{}", {"content-type": "text/plain"}),
    ]
    long_id = "z" * 8000
    cases += [  # unknown ids and bad queries
        ("GET", "/plan/unknown", None, {}),
        ("DELETE", "/plan/unknown", None, {}),
        ("GET", f"/plan/{long_id}", None, {}),
        ("POST", f"/plan/{long_id}/step", {}, {}),
        ("GET", "/maps/unknown", None, {}),
        ("GET", "/maps/..%2f..%2fetc%2fpasswd", None, {}),
        ("GET", f"/maps/{long_id}/render.png", None, {}),
        ("GET", f"/plan/{plan_id}/render.png?cell=0", None, {}),
        ("GET", f"/maps/{map_id}/render.png?cell={10**20}", None, {}),
        ("GET", f"/maps/{map_id}/render.png?preset=nope", None, {}),
        ("GET", f"/plan/{plan_id}/render.png?field={'f' * 5000}", None, {}),
        ("PUT", "/plan", {}, {}),
    ]
    return cases


def test_hostile_requests_get_small_4xx_never_5xx(client: httpx.Client, server: Replica) -> None:
    map_id, plan_id, _ = _plan(client)
    cases = _hostile(map_id, plan_id)
    assert len(cases) >= 40
    for method, url, body, headers in cases:
        if isinstance(body, bytes):
            r = client.request(method, url, content=body, headers=headers)
        else:
            r = client.request(method, url, json=body, headers=headers)
        what = f"{method} {url[:60]} {str(body)[:60]}"
        assert 400 <= r.status_code < 500, (what, r.status_code, r.text[:300])
        assert len(r.content) < 2000, what
        assert not any(word in r.text for word in INTERNALS), (what, r.text[:300])
    assert client.get(f"/plan/{plan_id}").status_code == 200  # the service is fine
    assert "Traceback" not in server.log.read_text()


def _connect(server: Replica) -> socket.socket:
    return socket.create_connection(("127.0.0.1", server.port), timeout=10)


def test_a_declared_huge_body_is_refused_without_being_sent(server: Replica) -> None:
    with _connect(server) as sock:
        sock.sendall(
            b"POST /maps HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
            b"Content-Length: 1000000000000\r\n\r\n"
        )
        answer = sock.recv(4096)
    assert answer.startswith(b"HTTP/1.1 413"), answer[:100]


def test_a_slow_body_gets_408_and_its_connection_closed(server: Replica) -> None:
    with _connect(server) as sock:
        sock.sendall(
            b"POST /plan HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
            b"Content-Length: 1000\r\n\r\n{"
        )
        t0 = time.monotonic()
        answer = b""
        while True:  # the server closes the connection after its answer
            chunk = sock.recv(4096)
            if not chunk:
                break
            answer += chunk
        elapsed = time.monotonic() - t0
    assert answer.startswith(b"HTTP/1.1 408"), answer[:200]
    assert b"PLANNER_BODY_TIMEOUT_SECONDS" in answer
    assert 2.5 < elapsed < 8


def test_healthz_answers_while_hundreds_of_connections_trickle_bodies(server: Replica) -> None:
    tricklers = []
    try:
        for _ in range(300):
            sock = _connect(server)
            sock.sendall(
                b"POST /plan HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                b"Content-Length: 60000\r\n\r\n{"
            )
            tricklers.append(sock)
        with httpx.Client(base_url=server.url, trust_env=False) as probe:
            for _ in range(5):
                t0 = time.monotonic()
                assert probe.get("/healthz").status_code == 200
                assert time.monotonic() - t0 < 0.5
        # Each gets its 408 within the body timeout, and is closed.
        deadline = time.monotonic() + 10
        for sock in tricklers:
            sock.settimeout(max(0.1, deadline - time.monotonic()))
            assert sock.recv(64).startswith(b"HTTP/1.1 408")
    finally:
        for sock in tricklers:
            sock.close()


def test_an_aborted_upload_logs_one_line_and_no_traceback(server: Replica) -> None:
    before = server.log.read_text()
    for _ in range(3):
        with _connect(server) as sock:
            sock.sendall(
                b"POST /maps HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                b"Content-Length: 100000\r\n\r\n" + b'{"rows": ["' + b"." * 1000
            )
            time.sleep(0.1)
    time.sleep(0.5)
    with httpx.Client(base_url=server.url, trust_env=False) as c:
        assert c.get("/healthz").status_code == 200
    added = server.log.read_text()[len(before) :]
    assert "Traceback" not in added
    assert added.count("client gone during its request POST /maps") == 3  # a line each


def _rss_kib(pid: int) -> int:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(next(line.split()[1] for line in status.splitlines() if line.startswith("VmRSS")))


def test_unknown_ids_leave_no_memory_behind(client: httpx.Client, server: Replica) -> None:
    def burst(start: int, count: int) -> None:
        for i in range(start, start + count):
            r = client.post(f"/plan/{'q' * 8000}{i}/step", json={"dynamic_obstacles": []})
            assert r.status_code == 404

    burst(0, 200)  # warm: allocator pools and caches reach their size
    before = _rss_kib(server.process.pid)
    burst(200, 1200)  # 10 MB of ids and locks: kept, they would show
    grown = _rss_kib(server.process.pid) - before
    assert grown < 5 * 1024, f"RSS grew {grown} KiB over 1200 steps to unknown plans"


def test_healthz_answers_quickly_while_a_long_simulation_runs(
    client: httpx.Client, server: Replica
) -> None:
    r = client.post("/maps", json={"rows": serpentine(301, 300)})
    map_id = r.json()["map_id"]
    body = {"start": [0, 0], "goal": [300, 299], "max_steps": 500_000, "preset": "shortest"}
    answers: list[httpx.Response] = []
    worker = threading.Thread(
        target=lambda: answers.append(client.post(f"/maps/{map_id}/simulate", json=body))
    )
    worker.start()
    try:
        time.sleep(0.3)
        with httpx.Client(base_url=server.url, trust_env=False) as probe:
            for _ in range(10):
                t0 = time.monotonic()
                assert probe.get("/healthz").status_code == 200
                assert time.monotonic() - t0 < 0.5
                time.sleep(0.05)
    finally:
        worker.join(timeout=30)
    assert answers[0].status_code in (200, 504)


def _race(client_a: httpx.Client, client_b: httpx.Client, trials: int) -> None:
    """DELETE racing a replanning step: the plan stays deleted every time."""
    for trial in range(trials):
        _, plan_id, preview = _plan(client_a)
        results: dict[str, int] = {}

        def stepping(
            plan_id: str = plan_id, cell: list[int] = preview[1], results: dict[str, int] = results
        ) -> None:
            body = {"dynamic_obstacles": [cell]}
            results["step"] = client_a.post(f"/plan/{plan_id}/step", json=body).status_code

        worker = threading.Thread(target=stepping)
        worker.start()
        if trial % 2:
            time.sleep(0.002)
        deleted = client_b.delete(f"/plan/{plan_id}")
        worker.join(timeout=30)
        assert deleted.status_code == 204
        assert results["step"] in (200, 404)
        assert client_a.get(f"/plan/{plan_id}").status_code == 404
        assert client_b.get(f"/plan/{plan_id}").status_code == 404
        assert client_a.post(f"/plan/{plan_id}/step", json={}).status_code == 404


def test_delete_racing_a_step_on_the_memory_store(server: Replica) -> None:
    with (
        httpx.Client(base_url=server.url, trust_env=False, timeout=30) as a,
        httpx.Client(base_url=server.url, trust_env=False, timeout=30) as b,
    ):
        _race(a, b, 40)


def test_delete_racing_a_step_on_redis(redis_server: RedisServer, tmp_path: Path) -> None:
    with (
        replicas(redis_server.url, tmp_path, 2) as (one, two),
        httpx.Client(base_url=one.url, trust_env=False, timeout=30) as a,
        httpx.Client(base_url=two.url, trust_env=False, timeout=30) as b,
    ):
        _race(a, b, 40)
        _race(a, a, 10)  # on one replica too


def test_a_replica_killed_mid_step_leaves_nothing_held(
    redis_server: RedisServer, tmp_path: Path
) -> None:
    env = {"PLANNER_POOL_SIZE": "1", "PLANNER_MAX_MAP_CELLS": str(1 << 22)}
    with (
        replicas(redis_server.url, tmp_path, 2, env) as (one, two),
        httpx.Client(base_url=one.url, trust_env=False, timeout=60) as a,
        httpx.Client(base_url=two.url, trust_env=False, timeout=60) as b,
    ):
        _, plan_id, _ = _plan(a)  # analysed on one only
        # Two's only heavy worker runs a long episode (~180,000 steps, seconds)...
        big = b.post("/maps", json={"rows": serpentine(901, 600)}).json()["map_id"]
        episode: dict[str, Any] = {"start": [0, 0], "goal": [900, 599], "max_steps": 200_000}
        episode["preset"] = "shortest"
        threading.Thread(
            target=lambda: _quietly(b.post, f"/maps/{big}/simulate", json=episode),
            daemon=True,
        ).start()
        # Past the episode's analysis and plan (a step's analysis queued before the episode
        # would run first: its goal wave is made without the pool).
        time.sleep(2.0)
        # ...so a step there, needing the plan's analysis, is mid-step while it waits.
        stepping = threading.Thread(
            target=lambda: _quietly(b.post, f"/plan/{plan_id}/step", json={}), daemon=True
        )
        stepping.start()
        time.sleep(1.0)
        assert stepping.is_alive(), "the step on two was not held up"
        store = redis.Redis.from_url(redis_server.url)
        try:
            two.kill()  # SIGKILL, mid-step
            keys = sorted(k.decode() if isinstance(k, bytes) else k for k in store.keys("*"))
            kinds = sorted(k.rsplit(":", 1)[0] for k in keys)
            # The maps, the plan, its path and the set of live plans: no lock, nothing else.
            expected = ["planner:map"] * 2 + ["planner:path", "planner:plan", "planner:plans-of"]
            assert kinds == expected, keys
        finally:
            store.close()
        t0 = time.monotonic()
        stepped = a.post(f"/plan/{plan_id}/step", json={})
        assert stepped.status_code == 200, stepped.text
        assert time.monotonic() - t0 < 1.0  # nothing to wait for
        assert stepped.json()["iteration"] == 1  # the dead replica's step was never recorded


def _quietly(call: Any, *args: Any, **kwargs: Any) -> None:
    """A request whose server may be killed under it."""
    with contextlib.suppress(httpx.HTTPError):
        call(*args, **kwargs)

"""``docker/nginx.conf`` for real: Debian's nginx, with the file's upstream line pointed at two
local ``python -m service`` replicas sharing a redis-server. A plan made through nginx is stepped
through nginx, the steps land on both replicas (their JSON logs say which), a live viewer's event
stream through nginx receives every step, and X-Request-ID goes through both ways."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import orjson
import pytest

from tests.service.conftest import ROOT, RedisServer, free_port, random_map
from tests.service.test_viewer import events

CONF = ROOT / "docker" / "nginx.conf"
UPSTREAM = re.compile(r"^(\s*)server planner:8000 resolve;$", re.MULTILINE)
LISTEN = re.compile(r"^(\s*)listen 80;$", re.MULTILINE)


def nginx_binary() -> str:
    """nginx's path; skips without it, but fails in CI, whose ``.ci/run`` installs it."""
    path = shutil.which("nginx") or shutil.which("nginx", path="/usr/sbin:/sbin")
    if path is None:
        msg = "nginx is not installed (apt-get install nginx; .ci/run does so)"
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    return path


def local_conf(upstreams: list[int], port: int) -> str:
    """docker/nginx.conf with its upstream server line and its listen line made local."""
    text = CONF.read_text(encoding="utf-8")
    servers = "".join(f"\\1server 127.0.0.1:{p};\n" for p in upstreams).rstrip("\n")
    text, n = UPSTREAM.subn(servers, text)
    assert n == 1, "docker/nginx.conf has no line `server planner:8000 resolve;`"
    text, n = LISTEN.subn(f"\\1listen 127.0.0.1:{port};", text)
    assert n == 1, "docker/nginx.conf has no line `listen 80;`"
    return text


class Service:
    """``python -m service`` in a process of its own, its JSON lines in a file."""

    def __init__(self, store_url: str, log: Path) -> None:
        self.port = free_port()
        self.log = log
        env = {
            **os.environ,
            "PLANNER_STORE_URL": store_url,
            "PLANNER_PORT": str(self.port),
            "PLANNER_POOL_SIZE": "1",
            "PYTHONUNBUFFERED": "1",
        }
        with log.open("wb") as out:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "service"], env=env, cwd=ROOT, stdout=out, stderr=out
            )

    def wait_ready(self) -> None:
        wait_for(f"http://127.0.0.1:{self.port}/readyz", self.process, self.log)

    def stop(self) -> list[dict[str, Any]]:
        """Stop it (SIGTERM, as a container's stop does) and return its log lines."""
        if self.process.poll() is None:
            self.process.terminate()
        self.process.wait(timeout=60)
        return [orjson.loads(line) for line in self.log.read_bytes().splitlines()]


def wait_for(url: str, process: subprocess.Popen[bytes], log: Path) -> None:
    deadline = time.monotonic() + 120
    while True:
        assert process.poll() is None, log.read_text()
        assert time.monotonic() < deadline, f"{url} did not answer: {log.read_text()}"
        try:
            if httpx.get(url, timeout=5, trust_env=False).status_code == 200:
                return
        except httpx.TransportError:
            pass
        time.sleep(0.05)


@pytest.fixture
def nginx_in_front(
    redis_server: RedisServer, tmp_path: Path
) -> Iterator[tuple[str, list[Service]]]:
    binary = nginx_binary()
    services: list[Service] = []
    nginx: subprocess.Popen[bytes] | None = None
    try:
        for i in range(2):
            services.append(Service(redis_server.url, tmp_path / f"service-{i}.log"))
        for service in services:
            service.wait_ready()
        port = free_port()
        prefix = tmp_path / "nginx"
        prefix.mkdir()
        conf = prefix / "nginx.conf"
        conf.write_text(local_conf([s.port for s in services], port), encoding="utf-8")
        globals_ = f"pid {prefix}/nginx.pid; error_log {prefix}/error.log;"
        args = [binary, "-p", f"{prefix}/", "-c", str(conf)]
        check = subprocess.run([*args, "-t", "-g", globals_], capture_output=True, text=True)
        assert check.returncode == 0, check.stderr  # nginx 1.22 takes the file as it is
        log = prefix / "stderr.log"
        with log.open("wb") as out:
            nginx = subprocess.Popen([*args, "-g", f"daemon off; {globals_}"], stderr=out)
        wait_for(f"http://127.0.0.1:{port}/healthz", nginx, log)
        yield f"http://127.0.0.1:{port}", services
    finally:
        if nginx is not None:
            nginx.terminate()
            nginx.wait(timeout=30)
        for service in services:
            if service.process.poll() is None:
                service.process.kill()
                service.process.wait(timeout=30)


def test_a_plan_made_and_stepped_through_nginx_lands_on_both_replicas(
    nginx_in_front: tuple[str, list[Service]],
) -> None:
    url, services = nginx_in_front
    grid = random_map(24, 24, 0.15, seed=3).tolist()
    sent: dict[str, int] = {}
    with httpx.Client(base_url=url, trust_env=False, timeout=60) as client:
        assert client.get("/healthz").status_code == 200
        r = client.post("/maps", json={"grid": grid, "start": [0, 0], "goal": [23, 23]})
        assert r.status_code == 201, r.text
        made = r.headers["x-request-id"]  # nginx made it: the client sent none
        assert re.fullmatch(r"[0-9a-f]{32}", made)
        plan_id = r.json()["plan"]["plan_id"]
        path = r.json()["plan"]["preview"]["path"]
        watched: list[dict[str, Any]] = []
        connected = threading.Event()

        def watch() -> None:  # the live viewer's stream, on whichever replica nginx picks
            timeout = httpx.Timeout(10, read=60)
            with (
                httpx.Client(base_url=url, trust_env=False, timeout=timeout) as watcher,
                watcher.stream("GET", f"/plan/{plan_id}/events") as stream,
            ):
                assert stream.status_code == 200
                connected.set()
                for event in events(stream.iter_lines()):
                    watched.append(event)
                    if event["status"] == "arrived":
                        return

        watching = threading.Thread(target=watch, daemon=True)
        watching.start()
        assert connected.wait(30)
        for seq in range(len(path) - 1):
            request_id = f"nginx-step-{seq}"
            r = client.post(
                f"/plan/{plan_id}/step", json={"seq": seq}, headers={"X-Request-ID": request_id}
            )
            assert r.status_code == 200, r.text
            assert r.headers["x-request-id"] == request_id
            assert r.json()["position"] == path[seq + 1]
            sent[request_id] = seq
        assert r.json()["status"] == "arrived"
        detail = client.get(f"/plan/{plan_id}")
        assert detail.json()["trajectory"] == path
        watching.join(timeout=5)
        # Every step reached the stream, whichever replica served it (Redis pub/sub).
        assert [e["seq"] for e in watched] == list(range(len(path) - 1))
        assert [e["position"] for e in watched] == path[1:]

    logs = [service.stop() for service in services]
    steps = [
        {
            line["request_id"]
            for line in lines
            if line.get("route") == "/plan/{plan_id}/step" and line["status"] == 200
        }
        for lines in logs
    ]
    assert all(steps), f"steps on one replica only: {[len(s) for s in steps]}"
    assert steps[0].isdisjoint(steps[1])
    assert steps[0] | steps[1] == set(sent)
    uploads = [line for lines in logs for line in lines if line.get("route") == "/maps"]
    assert [line["request_id"] for line in uploads] == [made]

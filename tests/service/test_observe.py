"""``X-Request-ID`` on every answer, and ``python -m service``'s JSON log lines: one per request,
start-up lines before and after the warm-up, and never the store's password."""

from __future__ import annotations

import asyncio
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx
import orjson
import pytest
import redis

from service.ops.logs import RequestLines
from tests.service.conftest import ROOT, RedisServer, free_port

pytestmark = pytest.mark.anyio

REQUESTS: list[tuple[str, str, dict[str, Any] | None, int, str]] = [
    ("GET", "/healthz", None, 200, "/healthz"),
    ("GET", "/plan/0123abcd", None, 404, "/plan/{plan_id}"),
    ("POST", "/maps", {"grid": "not a grid"}, 422, "/maps"),
    ("POST", "/maps", {"grid": [[0, 0], [0, 1]]}, 201, "/maps"),
    ("GET", "/no/such/path", None, 404, "unmatched"),
]


@pytest.mark.parametrize(("method", "url", "body", "status", "route"), REQUESTS)
async def test_the_request_id_is_echoed_or_generated(
    client: httpx.AsyncClient,
    method: str,
    url: str,
    body: dict[str, Any] | None,
    status: int,
    route: str,
) -> None:
    given = await client.request(method, url, json=body, headers={"X-Request-ID": "trace-42.a"})
    assert given.status_code == status
    assert given.headers["x-request-id"] == "trace-42.a"
    made = [(await client.request(method, url, json=body)).headers["x-request-id"] for _ in "abc"]
    assert all(re.fullmatch(r"[0-9a-f]{32}", m) for m in made)
    assert len(set(made)) == 3


async def test_a_request_id_that_is_not_a_plain_token_is_replaced(
    client: httpx.AsyncClient,
) -> None:
    for bad in ["x" * 129, "a b", "<script>"]:
        r = await client.get("/healthz", headers={"X-Request-ID": bad})
        assert re.fullmatch(r"[0-9a-f]{32}", r.headers["x-request-id"])


async def test_a_body_refused_before_parsing_has_a_request_id(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", content=b"0" * 70_000, headers={"X-Request-ID": "big"})
    assert r.status_code == 413
    assert r.headers["x-request-id"] == "big"


def _lines(output: str) -> list[dict[str, Any]]:
    """Every line printed, each of which must be a JSON object."""
    lines = []
    for text in output.splitlines():
        line = orjson.loads(text)  # a plain-text line fails here
        assert isinstance(line, dict), text
        lines.append(line)
    return lines


def test_python_m_service_logs_json_lines_and_never_the_password(tmp_path: Path) -> None:
    secret = "s3cret-Pa55"
    server = RedisServer(tmp_path / "redis")
    server.start()
    process = None
    try:
        admin = redis.Redis(host="127.0.0.1", port=server.port)
        admin.config_set("requirepass", secret)
        admin.close()
        port = free_port()
        env = {
            **os.environ,
            "PLANNER_STORE_URL": f"redis://:{secret}@127.0.0.1:{server.port}/0",
            "PLANNER_PORT": str(port),
            "PLANNER_POOL_SIZE": "1",
        }
        out = (tmp_path / "service.log").open("w+b")
        process = subprocess.Popen(
            [sys.executable, "-m", "service"], env=env, cwd=ROOT, stdout=out, stderr=out
        )
        url = f"http://127.0.0.1:{port}"
        answers = []
        with httpx.Client(base_url=url, trust_env=False, timeout=60) as client:
            deadline = time.monotonic() + 120
            while True:
                assert process.poll() is None, (tmp_path / "service.log").read_text()
                assert time.monotonic() < deadline, "python -m service did not start"
                try:
                    first = client.get("/healthz", headers={"X-Request-ID": "probe-0"})
                    break
                except httpx.TransportError:
                    time.sleep(0.05)
            answers.append((first, "GET", "/healthz"))
            for method, path, body, status, route in REQUESTS:
                r = client.request(method, path, json=body)
                assert r.status_code == status, r.text
                answers.append((r, method, route))
            for path in ("/readyz", "/metrics"):
                r = client.get(path)
                assert r.status_code == 200
                assert secret not in r.text
                answers.append((r, "GET", path))
        assert secret not in first.text
        process.send_signal(signal.SIGTERM)
        # uvicorn shuts down, then re-raises the signal it caught
        assert process.wait(timeout=60) in (0, -signal.SIGTERM)
        out.seek(0)
        output = out.read().decode()
    finally:
        if process is not None and process.poll() is None:
            process.kill()
            process.wait(timeout=30)
        server.stop()

    assert secret not in output
    lines = _lines(output)
    assert all({"time", "level", "message"} <= set(line) for line in lines)
    requests = [line for line in lines if line.get("logger") == "service.access"]
    assert len(requests) == len(answers)  # exactly one line per request
    # A line is written once its answer is sent: the next request's may come first.
    by_id = {line["request_id"]: line for line in requests}
    assert len(by_id) == len(requests)
    for answer, method, route in answers:
        line = by_id[answer.headers["x-request-id"]]
        assert line["method"] == method
        assert line["route"] == route
        assert line["status"] == answer.status_code
        assert isinstance(line["status"], int)
        assert isinstance(line["duration_ms"], float)
        assert line["level"] == "info"
        assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", line["time"])
    assert "probe-0" in by_id
    assert not any("HTTP/1.1" in line["message"] for line in lines), "an access line"

    messages = [line["message"] for line in lines]
    warming = next(i for i, m in enumerate(messages) if m.startswith("warming up"))
    listening = next(i for i, m in enumerate(messages) if m == "listening")
    assert warming < listening < min(lines.index(line) for line in requests)
    started = lines[listening]
    assert started["address"] == url
    assert started["store"] == f"redis 127.0.0.1:{server.port}"
    (warmup,) = [key for key in started if "warmup" in key]
    assert started[warmup] >= 0


def test_request_lines_are_the_json_lines_logging_would_write_buffered(
    capsysbinary: pytest.CaptureFixture[bytes],
) -> None:
    """A request line has the fields of the service's other lines (time, level, logger,
    message) and its own, in that order; lines wait until ``max_lines`` are pending or a flush,
    and without an event loop go out at once."""
    lines = RequestLines(max_lines=3)
    fields = {"request_id": "r1", "method": "POST", "route": "/x", "status": 200}

    async def two_lines() -> None:
        lines.write({**fields, "duration_ms": 0.5})
        lines.write({**fields, "request_id": "r2", "duration_ms": 1.25})

    asyncio.run(two_lines())  # the loop ends before the timer: flushed by hand below
    assert capsysbinary.readouterr().out == b""
    lines.flush()
    out = [orjson.loads(line) for line in capsysbinary.readouterr().out.splitlines()]
    assert [list(line) for line in out] == [
        ["time", "level", "logger", "message", "request_id", "method", "route", "status",
         "duration_ms"]
    ] * 2  # fmt: skip
    assert out[0]["level"] == "info"
    assert out[0]["logger"] == "service.access"
    assert out[0]["message"] == "request"
    assert [line["request_id"] for line in out] == ["r1", "r2"]
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", out[0]["time"])

    async def many() -> None:  # 3 lines pending: out without waiting for the timer
        for i in range(7):
            lines.write({**fields, "request_id": f"m{i}"})

    asyncio.run(many())
    assert len(capsysbinary.readouterr().out.splitlines()) == 6
    lines.flush()
    capsysbinary.readouterr()
    lines.write(fields)  # no event loop: at once
    assert len(capsysbinary.readouterr().out.splitlines()) == 1


def test_request_lines_pending_go_out_within_the_flush_interval(
    capsysbinary: pytest.CaptureFixture[bytes],
) -> None:
    lines = RequestLines(flush_seconds=0.05)

    async def one_then_wait() -> bytes:
        lines.write({"request_id": "r"})
        assert capsysbinary.readouterr().out == b""
        await asyncio.sleep(0.2)
        return capsysbinary.readouterr().out

    assert orjson.loads(asyncio.run(one_then_wait()))["request_id"] == "r"

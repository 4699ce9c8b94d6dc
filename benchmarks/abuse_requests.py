"""Hostile requests and connections (issue 24): bodies, headers, circles and sockets whose size
would become time on the event loop or memory in the process. Each pattern takes the
:class:`Service` and returns what the attacker got (a status, or what happened)."""

from __future__ import annotations

import contextlib
import io
import socket
import time
from collections.abc import Callable

import numpy as np
import orjson
from abuse_service import ATTACKER, Service
from PIL import Image
from streams import CIRCLE, SIDE, open_stream

JSON = {"content-type": "application/json"}


def quiet(service: Service) -> str:
    time.sleep(3)
    return "-"


def alias_bomb(service: Service) -> str:
    lines = ["image: m.pgm", "resolution: 0.05", "origin: [0, 0, 0]"]
    lines.append('a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]')
    for prev, name in zip("abcdefgh", "bcdefghi", strict=True):
        lines.append(f"{name}: &{name} [{','.join([f'*{prev}'] * 9)}]")
    lines.append("mode: *i")
    files = {
        "yaml": ("m.yaml", "\n".join(lines).encode(), "application/yaml"),
        "image": ("m.pgm", b"P5 1 1 255 \0", "image/x-portable-graymap"),
    }
    with service.client() as c:
        return str(c.post("/maps", files=files).status_code)


def plan_on_big_map(service: Service) -> str:
    """A plan across a free 1000 x 1000 map at 0.05 m, the attacker's: its id."""
    body = {
        "rows": ["." * 1000] * 1000,
        "resolution": 0.05,
        "start": [500, 0],
        "goal": [500, 999],
        "preset": "shortest",
    }
    with service.client() as c:
        return str(c.post("/maps", json=body).json()["plan"]["plan_id"])


def circles(count: int, radius: float) -> Callable[[Service, str], str]:
    """A step with ``count`` circles of ``radius`` meters on the plan of :func:`plan_on_big_map`."""

    def attack(service: Service, plan_id: str) -> str:
        rng = np.random.default_rng(count)
        spots = rng.uniform(0, 50, (count, 2)).tolist()
        body = {"dynamic_obstacles": [{"x": x, "y": y, "radius": radius} for x, y in spots]}
        with service.client() as c:
            return str(c.post(f"/plan/{plan_id}/step", json=body).status_code)

    return attack


def million_keys(service: Service) -> str:
    body = b"{" + b",".join(b'"k%d":1' % i for i in range(1_000_000)) + b"}"
    with service.client() as c:
        r = c.post("/plan", content=body, headers=JSON)
    return f"{r.status_code} ({len(body) / 1e6:.0f} MB)"


def brackets(service: Service) -> str:
    body = b"[" * (32 << 20) + b"]"  # just over the limit: refused by its size
    body = body[: (32 << 20) - 16]
    with service.client() as c:
        r = c.post("/maps", content=body, headers=JSON)
    return f"{r.status_code} ({len(body) / 1e6:.0f} MB)"


def upload(side: int, encoding: str) -> Callable[[Service], str]:
    """A legal map upload of ``side`` x ``side`` cells, 20 % blocked, as JSON ``grid``,
    Moving AI ``rows``, or a PNG with its YAML (multipart)."""

    def attack(service: Service) -> str:
        rng = np.random.default_rng(side)
        grid = (rng.random((side, side)) < 0.2).astype(np.int8)
        url = "/maps"
        with service.client() as c:
            if encoding == "grid":
                body = orjson.dumps({"grid": grid}, option=orjson.OPT_SERIALIZE_NUMPY)
                r = c.post(url, content=body, headers=JSON)
            elif encoding == "rows":
                rows = np.where(grid == 1, ord("@"), ord(".")).astype(np.uint8)
                body = orjson.dumps({"rows": [bytes(row).decode() for row in rows]})
                r = c.post(url, content=body, headers=JSON)
            else:
                out = io.BytesIO()
                Image.fromarray(np.where(grid == 1, 0, 254).astype(np.uint8)).save(out, "PNG")
                body = out.getvalue()
                yaml = b"image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\n"
                r = c.post(url, files={"yaml": ("m.yaml", yaml), "image": ("m.png", body)})
        return f"{r.status_code} ({len(body) / 1e6:.1f} MB)"

    return attack


def idle_sockets(service: Service) -> str:
    sockets = [socket.create_connection(("127.0.0.1", service.port)) for _ in range(4100)]
    try:
        time.sleep(3)
        with service.client() as c:
            return f"API {c.get('/maps/unknown').status_code}"
    finally:
        for sock in sockets:
            sock.close()


def slowloris(service: Service) -> str:
    """200 connections each sending a header line a second, for 8 s: how many uvicorn still
    holds open at the end (it has no timeout for a request's head)."""
    sockets = [socket.create_connection(("127.0.0.1", service.port)) for _ in range(200)]
    for sock in sockets:
        sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        sock.setblocking(False)
    open_ = len(sockets)
    try:
        for _ in range(8):
            open_ = 0
            for sock in sockets:
                try:
                    sock.sendall(b"X-Slow: 1\r\n")
                    sock.recv(1)
                except BlockingIOError:
                    open_ += 1
                except OSError:
                    pass
            time.sleep(1)
    finally:
        for sock in sockets:
            sock.close()
    return f"{open_}/200 open after 8 s"


def huge_header(service: Service) -> str:
    with socket.create_connection(("127.0.0.1", service.port), timeout=30) as sock:
        sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\nX-Big: ")
        sent = 0
        with contextlib.suppress(OSError):
            for _ in range(64):
                sock.sendall(b"a" * (1 << 20))
                sent += 1
        answer = b""
        with contextlib.suppress(OSError):
            answer = sock.recv(64)
    status = answer.split(b" ")[1].decode() if answer.startswith(b"HTTP/") else "closed"
    return f"{status} after {sent} MB sent"


def stream_never_read(service: Service) -> str:
    """An event stream whose client reads nothing (a 4 KB receive buffer), behind 300 steps
    whose events are ~700 KB each: how the stream ended (``dropped``: its queue let go)."""
    with service.client(timeout=60) as c:
        grid = [[0] * SIDE for _ in range(SIDE)]
        r = c.post("/maps", json={"grid": grid, "start": [0, 0], "goal": [0, SIDE - 1]})
        plan_id = r.json()["plan"]["plan_id"]
        sock = open_stream(service.port, plan_id, ATTACKER)
        try:
            for _ in range(300):
                step = c.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": [CIRCLE]})
                assert step.status_code == 200, step.text
            sock.setblocking(False)
            seen = b""
            with contextlib.suppress(OSError):
                while chunk := sock.recv(1 << 20):
                    seen += chunk
        finally:
            sock.close()
            c.delete(f"/plan/{plan_id}")
    return "stream dropped" if b"event: dropped" in seen else "stream held"

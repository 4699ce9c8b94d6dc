"""Abuse against the real service, with its defaults: what each hostile request or connection
pattern costs everyone else.

Starts ``python -m service`` (the settings' defaults, the memory store) on a free port and, for
each pattern, polls ``/healthz`` every 50 ms on a fresh connection while the pattern runs: the
slowest answer (the stall a probe or another client sees) and the answers that were not 200,
beside the server's RSS growth (its peak during the pattern over its RSS before). The first row
is the quiet service, the same polling with nothing else going on. Targets (issue 24): no
pattern stalls ``/healthz`` over 0.5 s or grows RSS over 300 MB.

Run: ``.venv/bin/python benchmarks/abuse.py`` (about a minute; ``--only NAME`` for one row).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from multiprocessing import Event, Process, Queue
from multiprocessing.synchronize import Event as EventType
from pathlib import Path

import httpx
import numpy as np
import orjson
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, free_port
from streams import CIRCLE, SIDE, open_stream

STALL_TARGET = 0.5
RSS_TARGET_MB = 300.0
JSON = {"content-type": "application/json"}


def rss_mb(pid: int) -> float:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(status.split("VmRSS:")[1].split()[0]) / 1024


def cpu_model() -> str:
    out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    facts = dict(line.split(":", 1) for line in out.splitlines() if ":" in line)
    return f"{facts.get('Model name', '?').strip()}, {facts.get('CPU(s)', '?').strip()} CPUs"


@dataclass
class Watch:
    """``/healthz`` every 50 ms on a fresh connection, and the server's RSS, while it runs: in
    a process of its own, so that the attacker's own work (building a body) does not slow
    the probe."""

    stall: float = 0.0
    failures: int = 0
    peak_rss: float = 0.0


def _poll(url: str, pid: int, done: EventType, out: Queue[Watch]) -> None:
    watch = Watch(peak_rss=rss_mb(pid))
    fresh = httpx.Limits(max_keepalive_connections=0)
    with httpx.Client(base_url=url, trust_env=False, timeout=60, limits=fresh) as c:
        while not done.is_set():
            t0 = time.monotonic()
            try:
                ok = c.get("/healthz").status_code == 200
            except httpx.HTTPError:
                ok = False
            watch.stall = max(watch.stall, time.monotonic() - t0)
            watch.peak_rss = max(watch.peak_rss, rss_mb(pid))
            watch.failures += not ok
            done.wait(0.05)
    out.put(watch)


@contextlib.contextmanager
def watching(url: str, pid: int) -> Iterator[list[Watch]]:
    """The :class:`Watch` of the block, in the list yielded once it ends."""
    done = Event()
    out: Queue[Watch] = Queue()
    poller = Process(target=_poll, args=(url, pid, done, out), daemon=True)
    poller.start()
    time.sleep(0.5)
    result: list[Watch] = []
    try:
        yield result
    finally:
        time.sleep(0.2)
        done.set()
        result.append(out.get(timeout=120))
        poller.join(timeout=30)


class Service:
    """``python -m service`` with its defaults, on a free port, its log in a temporary file."""

    def __init__(self, env: dict[str, str]) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = tempfile.NamedTemporaryFile(prefix="abuse-", suffix=".log", delete=False)  # noqa: SIM115
        self.process = subprocess.Popen(
            [sys.executable, "-m", "service"],
            env={**os.environ, **env, "PLANNER_PORT": str(self.port)},
            cwd=ROOT,
            stdout=self.log,
            stderr=subprocess.STDOUT,
        )
        with httpx.Client(base_url=self.url, trust_env=False) as c:
            for _ in range(1200):
                assert self.process.poll() is None, Path(self.log.name).read_text()
                try:
                    c.get("/healthz", timeout=5)
                    return
                except httpx.TransportError:
                    time.sleep(0.1)
        raise RuntimeError("the service did not start")

    def stop(self) -> None:
        self.process.terminate()
        self.process.wait(timeout=30)
        Path(self.log.name).unlink(missing_ok=True)


# The patterns: each returns what the attacker got (a status, or what happened).


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
    r = httpx.post(f"{service.url}/maps", files=files, timeout=120, trust_env=False)
    return str(r.status_code)


def _plan_on_big_map(service: Service) -> str:
    body = {
        "rows": ["." * 1000] * 1000,
        "resolution": 0.05,
        "start": [500, 0],
        "goal": [500, 999],
        "preset": "shortest",
    }
    r = httpx.post(f"{service.url}/maps", json=body, timeout=120, trust_env=False)
    return str(r.json()["plan"]["plan_id"])


def circles(count: int, radius: float) -> Callable[[Service], str]:
    def attack(service: Service) -> str:
        plan_id = PLANS.setdefault(service.url, _plan_on_big_map(service))
        rng = np.random.default_rng(count)
        spots = rng.uniform(0, 50, (count, 2)).tolist()
        body = {"dynamic_obstacles": [{"x": x, "y": y, "radius": radius} for x, y in spots]}
        r = httpx.post(
            f"{service.url}/plan/{plan_id}/step", json=body, timeout=120, trust_env=False
        )
        return str(r.status_code)

    return attack


PLANS: dict[str, str] = {}


def million_keys(service: Service) -> str:
    body = b"{" + b",".join(b'"k%d":1' % i for i in range(1_000_000)) + b"}"
    r = httpx.post(f"{service.url}/plan", content=body, headers=JSON, timeout=120, trust_env=False)
    return f"{r.status_code} ({len(body) / 1e6:.0f} MB)"


def brackets(service: Service) -> str:
    body = b"[" * (32 << 20) + b"]"  # just over the limit: refused by its size
    body = body[: (32 << 20) - 16]
    r = httpx.post(f"{service.url}/maps", content=body, headers=JSON, timeout=120, trust_env=False)
    return f"{r.status_code} ({len(body) / 1e6:.0f} MB)"


def upload(side: int, encoding: str) -> Callable[[Service], str]:
    """A legal map upload of ``side`` x ``side`` cells, 20 % blocked, as JSON ``grid``,
    Moving AI ``rows``, or a PNG with its YAML (multipart)."""

    def attack(service: Service) -> str:
        rng = np.random.default_rng(side)
        grid = (rng.random((side, side)) < 0.2).astype(np.int8)
        url = f"{service.url}/maps"
        with httpx.Client(trust_env=False, timeout=300) as c:
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
        with httpx.Client(base_url=service.url, trust_env=False) as c:
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
    with httpx.Client(base_url=service.url, trust_env=False, timeout=60) as c:
        grid = [[0] * SIDE for _ in range(SIDE)]
        r = c.post("/maps", json={"grid": grid, "start": [0, 0], "goal": [0, SIDE - 1]})
        plan_id = r.json()["plan"]["plan_id"]
        sock = open_stream(service.port, plan_id)
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


def _ring(cx: float, cy: float, radius: float, n: int) -> list[dict[str, float]]:
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return [{"x": cx + radius * np.cos(a), "y": cy + radius * np.sin(a)} for a in angles]


def rezone(service: Service) -> str:
    """Zoning the last zoned map again, 20 times, each with 256 speed zones of 39 points (a
    request's limits): issue 36 saw the map's zones grow without bound (5,120 at the 20th), each
    put sum the zones of every map, ``GET /maps/{id}`` grow to 18 MB and a step cost 117 ms.
    The answer: the zonings' statuses, then ``GET /maps/{id}``'s size and a step's median time
    on the last map zoned."""
    statuses: dict[int, int] = {}
    with httpx.Client(base_url=service.url, trust_env=False, timeout=300) as c:
        body = {"rows": ["." * 200] * 200, "resolution": 0.05}
        map_id = c.post("/maps", json=body).json()["map_id"]
        for k in range(20):
            centers = [
                (0.3 + 0.6 * i + 0.01 * k, 0.3 + 0.6 * j) for i in range(16) for j in range(16)
            ]
            speed = [{"polygon": _ring(x, y, 0.2, 39), "max_speed": 0.3} for x, y in centers]
            r = c.post(f"/maps/{map_id}/zones", json={"speed": speed})
            statuses[r.status_code] = statuses.get(r.status_code, 0) + 1
            if r.status_code in (200, 201):
                map_id = r.json()["map_id"]
        size = len(c.get(f"/maps/{map_id}").content)
        plan = c.post("/plan", json={"map_id": map_id, "start": [100, 0], "goal": [100, 199]})
        plan_id = plan.json()["plan_id"]
        times = []
        for _ in range(20):
            t0 = time.monotonic()
            c.post(f"/plan/{plan_id}/step", json={})
            times.append(time.monotonic() - t0)
    zonings = ", ".join(f"{n} x {code}" for code, n in sorted(statuses.items()))
    return f"{zonings}; GET {size / 1e6:.2f} MB; step {1e3 * float(np.median(times)):.1f} ms"


def waypoints(service: Service) -> str:
    """A free 1024 x 1024 map at 0.05 m, a patrol of 8 waypoints between two cells, then 64
    waypoints spread over it (twice): issue 36 saw a 500 (a route's plan forgotten twice)."""
    with httpx.Client(base_url=service.url, trust_env=False, timeout=300) as c:
        body = {"rows": ["." * 1024] * 1024, "resolution": 0.05}
        map_id = c.post("/maps", json=body).json()["map_id"]
        ends = {"map_id": map_id, "start": [0, 0], "goal": [1023, 1023]}
        spread = np.random.default_rng(36).integers(0, 1024, (64, 2)).tolist()
        answers = []
        for points in ([[900, 100], [100, 900]] * 4, spread, spread):
            try:
                r = c.post("/plan", json={**ends, "waypoints": points})
                answers.append(str(r.status_code))
            except httpx.HTTPError as exc:  # a connection the server dropped
                answers.append(type(exc).__name__)
    return " ".join(answers)


PATTERNS: dict[str, tuple[str, Callable[[Service], str]]] = {
    "quiet": ("the quiet service (polling only)", quiet),
    "alias-bomb": ("YAML alias bomb: 9 levels of 9 aliases, ~480 bytes", alias_bomb),
    "big-circles": ("a step with 200 circles of 10^6 m on a 1000 x 1000 map", circles(200, 1e6)),
    "many-circles": ("a step with 2,000 circles of 5 m on that map", circles(2000, 5.0)),
    "million-keys": ("POST /plan, a body of 1 M unknown keys", million_keys),
    "brackets": ("POST /maps, 32 MB of `[` (the largest body)", brackets),
    "grid-1024": ("POST /maps, a 1024 x 1024 JSON `grid`", upload(1024, "grid")),
    "grid-2048": ("POST /maps, a 2048 x 2048 JSON `grid`", upload(2048, "grid")),
    "grid-3800": ("POST /maps, a 3800 x 3800 JSON `grid`", upload(3800, "grid")),
    "rows-3800": ("POST /maps, 3800 x 3800 Moving AI `rows`", upload(3800, "rows")),
    "png-3800": ("POST /maps, a 3800 x 3800 PNG and its YAML", upload(3800, "png")),
    "idle-sockets": ("4,100 idle TCP connections, held 3 s", idle_sockets),
    "slowloris": ("200 connections trickling header lines, 8 s", slowloris),
    "huge-header": ("one connection sending a 64 MB header", huge_header),
    "stream-never-read": (
        "an event stream never read, 300 steps of ~700 KB events",
        stream_never_read,
    ),
    "rezone": ("zoning the zoned map again, 20 x 256 speed zones", rezone),
    "waypoints": ("1024 x 1024 map: 8 waypoints, then 64 (twice)", waypoints),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", action="append", choices=sorted(PATTERNS), default=[])
    args = parser.parse_args()
    names = [n for n in PATTERNS if not args.only or n in args.only or n == "quiet"]
    service = Service({})
    print(f"CPU: {cpu_model()}; python -m service with its defaults, memory store.\n")
    print("| pattern | answer | took (s) | /healthz max (s) | not 200 | RSS growth (MB) | met |")
    print("|---|---|---|---|---|---|---|")
    try:
        for name in names:
            what, attack = PATTERNS[name]
            if name in ("big-circles", "many-circles"):
                PLANS.setdefault(service.url, _plan_on_big_map(service))
            before = rss_mb(service.process.pid)
            with watching(service.url, service.process.pid) as result:
                t0 = time.monotonic()
                answer = attack(service)
                took = time.monotonic() - t0
            watch = result[0]
            grown = watch.peak_rss - before
            met = watch.stall <= STALL_TARGET and grown <= RSS_TARGET_MB and not watch.failures
            failures = watch.failures
            print(
                f"| {what} | {answer} | {took:.2f} | {watch.stall:.3f} | {failures} | "
                f"{grown:.0f} | {'yes' if met else 'NO'} |",
                flush=True,
            )
    finally:
        service.stop()


if __name__ == "__main__":
    main()

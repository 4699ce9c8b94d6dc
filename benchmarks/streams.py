"""Event streams under abuse, side by side with the quiet service (issue 24, M1 and M3).

Starts ``uvicorn service.main:app`` (memory store, then Redis: a redis-server of its own) and
prints, per pattern, the server's RSS growth (``/proc/<pid>/status``) and the longest
``/healthz`` answer seen while it ran (polled every 50 ms from another thread):

- quiet: ``STEPS`` steps whose events are ~700 KB each (a wide circle), nobody listening;
- reading: the same with one event stream read as fast as it comes;
- never reading: the same with one stream whose client reads nothing (its receive buffer 4 KB);
- with Redis, 150 streams (one key; ``PLANNER_MAX_STREAMS_PER_TENANT=200``) on three plans: the
  replica's connections to Redis (``CLIENT LIST``), then one step heard by every stream.

Run: ``.venv/bin/python benchmarks/streams.py [STEPS]`` (default 900).
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import redis

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import free_port
from leaks import rss_mib

ROOT = Path(__file__).resolve().parents[1]
SIDE = 400
CIRCLE = {"x": 200.0, "y": 200.0, "radius": 150.0}
"""~70,000 cells: an event of ~700 KB."""


@contextmanager
def redis_server() -> Iterator[str]:
    port, directory = free_port(), tempfile.mkdtemp(prefix="streams-redis-")
    binary = shutil.which("redis-server")
    assert binary is not None, "redis-server is not on PATH"
    args = [binary, "--port", str(port), "--bind", "127.0.0.1", "--save", "", "--dir", directory]
    process = subprocess.Popen(args, stdout=subprocess.DEVNULL)
    try:
        client = redis.Redis(port=port)
        for _ in range(300):
            try:
                client.ping()
                break
            except redis.ConnectionError:
                time.sleep(0.05)
        yield f"redis://127.0.0.1:{port}/0"
    finally:
        process.kill()
        process.wait()
        shutil.rmtree(directory, ignore_errors=True)


@contextmanager
def service(store_url: str, **env: str) -> Iterator[tuple[int, int]]:
    """A replica: its port and pid."""
    port = free_port()
    environment = {**os.environ, "PLANNER_STORE_URL": store_url, "PLANNER_POOL_SIZE": "2", **env}
    args = [sys.executable, "-m", "uvicorn", "service.main:app", "--port", str(port)]
    server = subprocess.Popen([*args, "--log-level", "warning"], cwd=ROOT, env=environment)
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=5) as c:
            for _ in range(1200):
                try:
                    c.get("/healthz")
                    break
                except httpx.TransportError:
                    time.sleep(0.1)
        yield port, server.pid
    finally:
        server.terminate()
        server.wait(timeout=30)


def open_stream(port: int, plan_id: str, key: str = "") -> socket.socket:
    """A stream's socket, once subscribed (for API key ``key``, when given);
    ``ConnectionRefusedError`` when refused."""
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.connect(("127.0.0.1", port))
    auth = f"X-API-Key: {key}\r\n" if key else ""
    sock.sendall(f"GET /plan/{plan_id}/events HTTP/1.1\r\nHost: p\r\n{auth}\r\n".encode())
    seen = b""
    while b": subscribed" not in seen:
        chunk = sock.recv(4096)
        seen += chunk
        if not chunk or (len(seen) >= 12 and not seen.startswith(b"HTTP/1.1 200")):
            sock.close()
            raise ConnectionRefusedError(seen.split(b"\r\n", 1)[0].decode())
    return sock


def drain(sock: socket.socket, stop: threading.Event) -> None:
    sock.settimeout(0.2)
    while not stop.is_set():
        try:
            if not sock.recv(1 << 20):
                return
        except TimeoutError:
            continue


def healthz_worst(port: int, stop: threading.Event, out: list[float]) -> None:
    with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30) as c:
        while not stop.is_set():
            t0 = time.perf_counter()
            c.get("/healthz")
            out.append(time.perf_counter() - t0)
            time.sleep(0.05)


def pattern(port: int, pid: int, steps: int, listener: Callable[[str], Callable[[], None]]) -> str:
    """Steps with a listener set up by ``listener(plan_id)`` (which answers its own stop)."""
    with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=60) as c:
        grid = [[0] * SIDE for _ in range(SIDE)]
        r = c.post("/maps", json={"grid": grid, "start": [0, 0], "goal": [0, SIDE - 1]})
        plan_id = r.json()["plan"]["plan_id"]
        c.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": [CIRCLE]})  # warm
        before = rss_mib(pid)
        finish = listener(plan_id)
        stop, waits = threading.Event(), [0.0]
        poller = threading.Thread(target=healthz_worst, args=(port, stop, waits))
        poller.start()
        t0 = time.perf_counter()
        for _ in range(steps):
            answer = c.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": [CIRCLE]})
            assert answer.status_code == 200, answer.text
        took = time.perf_counter() - t0
        after = rss_mib(pid)
        stop.set()
        poller.join()
        finish()
        c.delete(f"/plan/{plan_id}")
    return (
        f"RSS {before:6.1f} -> {after:6.1f} MiB (+{after - before:5.1f}), "
        f"{steps / took:5.1f} steps/s, /healthz worst {max(waits) * 1000:5.1f} ms"
    )


def nobody(plan_id: str) -> Callable[[], None]:
    return lambda: None


def reader(port: int) -> Callable[[str], Callable[[], None]]:
    def listen(plan_id: str) -> Callable[[], None]:
        sock, stop = open_stream(port, plan_id), threading.Event()
        thread = threading.Thread(target=drain, args=(sock, stop))
        thread.start()

        def finish() -> None:
            stop.set()
            thread.join()
            sock.close()

        return finish

    return listen


def idler(port: int) -> Callable[[str], Callable[[], None]]:
    def listen(plan_id: str) -> Callable[[], None]:
        sock = open_stream(port, plan_id)
        return sock.close

    return listen


def many_streams(store_url: str) -> None:
    with (
        service(store_url, PLANNER_MAX_STREAMS_PER_TENANT="200") as (port, pid),
        httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=60) as c,
    ):
        plans = []
        for start in ([0, 0], [0, 1], [1, 0]):
            body = {"rows": ["...."] * 3, "start": start, "goal": [2, 3]}
            plans.append(c.post("/maps", json=body).json()["plan"]["plan_id"])
        before = rss_mib(pid)
        t0 = time.perf_counter()
        streams, refused = [], set()
        for i in range(150):
            try:
                streams.append(open_stream(port, plans[i % 3]))
            except ConnectionRefusedError as exc:
                refused.add(str(exc))
        opened = time.perf_counter() - t0
        clients = redis.Redis.from_url(store_url).client_list()
        subscribers = sum(1 for client in clients if int(client["sub"]) > 0)
        c.post(f"/plan/{plans[0]}/step", json={"seq": 0})
        heard = 0
        for sock in streams[::3]:  # plan 0's (streams open in order until refused)
            sock.settimeout(10)
            seen = b""
            while b'"seq":0' not in seen:
                seen += sock.recv(65536)
            heard += 1
        print(
            f"redis, 150 streams: {len(streams)} opened in {opened:.2f} s (refused: "
            f"{sorted(refused) or 'none'}), {len(clients) - 1} connections to Redis "
            f"({subscribers} pub/sub), the step heard by {heard}/{len(streams[::3])} streams on "
            f"its plan; RSS {before:.1f} -> {rss_mib(pid):.1f} MiB"
        )
        for sock in streams:
            sock.close()


def main() -> None:
    steps = int(sys.argv[1]) if len(sys.argv) > 1 else 900
    print(f"{steps} steps, events of ~700 KB; CPU: {cpu()}")
    with service("memory://") as (port, pid):
        for name, listener in [("quiet", nobody), ("reading", reader(port)),
                               ("never reading", idler(port))]:  # fmt: skip
            print(f"memory, {name:13}: {pattern(port, pid, steps, listener)}")
    with redis_server() as url:
        with service(url) as (port, pid):
            for name, listener in [("quiet", nobody), ("never reading", idler(port))]:
                print(f"redis,  {name:13}: {pattern(port, pid, steps, listener)}")
        many_streams(url)


def cpu() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return f"{line.split(':', 1)[1].strip()}, {os.cpu_count()} vCPUs"
    return "unknown"


if __name__ == "__main__":
    main()

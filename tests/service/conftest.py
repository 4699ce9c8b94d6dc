"""Fixtures of the service tests: an app over ASGI (lifespan run), a live uvicorn server, and
for the shared store a real redis-server and uvicorn processes, all on 127.0.0.1."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager, contextmanager
from pathlib import Path

import anyio
import httpx
import numpy as np
import pytest
import redis
import uvicorn
from fastapi import FastAPI

from service.config import Settings
from service.main import create_app

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"


SMALL = Settings(pool_size=2, max_map_cells=4096, max_body_bytes=65536, max_dynamic_obstacles=20)
"""Small limits, so that the limit tests need small bodies."""


@pytest.fixture
def settings() -> Settings:
    return SMALL


@pytest.fixture
def app(settings: Settings) -> FastAPI:
    return create_app(settings)


@asynccontextmanager
async def running(app: FastAPI) -> AsyncIterator[None]:
    """The app's lifespan, entered once every kernel is loaded. A service is ready once its
    own kernels are, the rest loading in the background: a test starts as a warm service runs
    (steps decided on the event loop, ``pool_warm`` still), unless its settings ask for no
    wait (``warmup_wait_seconds`` 0)."""
    async with app.router.lifespan_context(app):
        pool, deadline = app.state.engine.pool, time.monotonic() + 600
        while not pool.warm and app.state.engine.settings.warmup_wait_seconds > 0:
            assert time.monotonic() < deadline, "the background warm-up never ended"
            await anyio.sleep(0.01)
        yield


@pytest.fixture
async def client(app: FastAPI) -> AsyncIterator[httpx.AsyncClient]:
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            yield c


@pytest.fixture(scope="module")
def live_url() -> Iterator[str]:
    """A uvicorn server on 127.0.0.1, on a port the OS picked, for this module's tests."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    server = uvicorn.Server(
        uvicorn.Config(create_app(Settings(pool_size=2)), log_level="warning", lifespan="on")
    )
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + 120
    while not server.started:
        assert thread.is_alive(), "uvicorn stopped"
        assert time.monotonic() < deadline, "uvicorn did not start"
        time.sleep(0.02)
    yield f"http://127.0.0.1:{port}"
    server.should_exit = True
    thread.join(timeout=30)
    sock.close()


def random_map(height: int, width: int, density: float, seed: int) -> np.ndarray:
    """A random 0/1 grid, free along its border so that corners are reachable more often."""
    rng = np.random.default_rng(seed)
    grid = (rng.random((height, width)) < density).astype(np.uint8)
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 0
    return grid


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def redis_server_binary() -> str:
    """``redis-server``'s path; skips without it, but fails in CI, whose ``.ci/run`` installs it."""
    path = shutil.which("redis-server")
    if path is None:
        msg = "redis-server is not on PATH (apt-get install redis-server; .ci/run does so)"
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    return path


class RedisServer:
    """A redis-server on 127.0.0.1 in a directory of its own. With ``persistent``, every write
    is fsynced to an append-only file, so a server killed and started again keeps its data."""

    def __init__(self, directory: Path, *, persistent: bool = False) -> None:
        self.binary = redis_server_binary()
        self.directory = directory
        self.directory.mkdir(parents=True, exist_ok=True)
        self.persistent = persistent
        self.port = free_port()
        self.url = f"redis://127.0.0.1:{self.port}/0"
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        aof = ["yes", "--appendfsync", "always"] if self.persistent else ["no"]
        args = [
            self.binary, "--port", str(self.port), "--bind", "127.0.0.1", "--dir",
            str(self.directory), "--save", "", "--appendonly", *aof, "--loglevel", "warning",
        ]  # fmt: skip
        with (self.directory / "redis.log").open("ab") as log:
            self.process = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT)
        client = redis.Redis(host="127.0.0.1", port=self.port, socket_connect_timeout=1)
        deadline = time.monotonic() + 30
        try:
            while True:
                assert self.process.poll() is None, (self.directory / "redis.log").read_text()
                assert time.monotonic() < deadline, "redis-server did not answer"
                try:
                    if client.ping():
                        return
                except redis.exceptions.RedisError:  # refused, or still loading its data
                    time.sleep(0.02)
        finally:
            client.close()

    def stop(self) -> None:
        """Kill it, as a crash would."""
        if self.process is not None:
            self.process.kill()
            self.process.wait(timeout=30)
            self.process = None


@pytest.fixture
def redis_server(tmp_path: Path) -> Iterator[RedisServer]:
    server = RedisServer(tmp_path / "redis")
    server.start()
    try:
        yield server
    finally:
        server.stop()


class Replica:
    """The service as uvicorn runs it in production, in a process of its own, on 127.0.0.1."""

    def __init__(
        self, store_url: str, log: Path, env: dict[str, str] | None = None, *, main: bool = False
    ) -> None:
        """``main``: started as ``python -m service`` starts it (its connection limits and
        timeouts from the settings), else by the ``uvicorn`` command with its defaults."""
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = log
        env = {
            **os.environ, "PLANNER_STORE_URL": store_url, "PLANNER_POOL_SIZE": "1", **(env or {})
        }  # fmt: skip
        args = [sys.executable, "-m", "uvicorn", "service.main:app", "--host", "127.0.0.1"]
        args += ["--port", str(self.port), "--log-level", "warning"]
        if main:
            args = [sys.executable, "-m", "service"]
            env |= {"PLANNER_HOST": "127.0.0.1", "PLANNER_PORT": str(self.port)}
        with log.open("ab") as out:
            self.process = subprocess.Popen(
                args, env=env, cwd=ROOT, stdout=out, stderr=subprocess.STDOUT
            )

    def wait_ready(self) -> None:
        """Until it answers, and every kernel is compiled (``/readyz``'s ``pool.warm``, whatever
        the store's state): a test's requests never wait for a compile, nor share the CPU with
        the background warm-up."""
        deadline = time.monotonic() + 120
        with httpx.Client(base_url=self.url, trust_env=False) as client:
            while True:
                assert self.process.poll() is None, self.log.read_text()
                assert time.monotonic() < deadline, f"uvicorn did not start: {self.log.read_text()}"
                try:
                    if client.get("/readyz", timeout=5).json()["pool"]["warm"]:
                        return
                except httpx.TransportError:
                    pass
                time.sleep(0.05)

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait(timeout=30)


@contextmanager
def replicas(
    store_url: str,
    directory: Path,
    count: int,
    env: dict[str, str] | None = None,
    *,
    main: bool = False,
) -> Iterator[list[Replica]]:
    """``count`` uvicorn processes sharing ``store_url``, stopped on the way out (``main``:
    each started as ``python -m service``)."""
    started: list[Replica] = []
    try:
        for i in range(count):
            started.append(Replica(store_url, directory / f"uvicorn-{i}.log", env, main=main))
        for replica in started:
            replica.wait_ready()
        yield started
    finally:
        for replica in started:
            replica.kill()

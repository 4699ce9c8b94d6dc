"""Fixtures of the service tests: an app over ASGI (lifespan run) and a live uvicorn server."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import AsyncIterator, Iterator

import httpx
import numpy as np
import pytest
import uvicorn
from fastapi import FastAPI

from service.config import Settings
from service.main import create_app


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture
def settings() -> Settings:
    # Small limits, so that the limit tests need small bodies.
    return Settings(pool_size=2, max_map_cells=4096, max_body_bytes=65536, max_dynamic_obstacles=20)


@pytest.fixture
def app(settings: Settings) -> FastAPI:
    return create_app(settings)


@pytest.fixture
async def client(app: FastAPI) -> AsyncIterator[httpx.AsyncClient]:
    async with app.router.lifespan_context(app):
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

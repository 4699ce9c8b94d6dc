"""``python -m service``: the service under uvicorn on ``PLANNER_HOST``:``PLANNER_PORT``, as
``make run`` and the container start it, logging JSON lines on stdout."""

from __future__ import annotations

import socket

import uvicorn

from service.config import Settings
from service.ops.logs import LOG, configure

__all__ = ["KEEP_ALIVE_SECONDS", "MAX_CONCURRENCY", "main"]

KEEP_ALIVE_SECONDS = 5
"""Seconds an idle keep-alive connection stays open."""
MAX_CONCURRENCY = 4096
"""Connections and requests at once; beyond, uvicorn answers 503 at once."""


class _Server(uvicorn.Server):
    async def startup(self, sockets: list[socket.socket] | None = None) -> None:
        await super().startup(sockets=sockets)
        if self.should_exit:  # the lifespan failed, or the port was taken
            return
        from service.main import app  # the module uvicorn loaded, with its lifespan's facts

        bound = [s.getsockname() for server in self.servers for s in server.sockets or ()]
        addresses = [f"http://{a[0]}:{a[1]}" for a in bound if isinstance(a, tuple)]
        fields = {"address": addresses[0] if addresses else None, **app.state.startup}
        LOG.info("listening", extra={"fields": fields})


def main() -> int:
    """Serve until stopped (Ctrl-C, SIGTERM); 1 when the service could not start."""
    settings = Settings()
    config = configure(settings.log_level)
    server = _Server(
        uvicorn.Config(
            "service.main:app",
            host=settings.host,
            port=settings.port,
            log_config=config,
            access_log=False,  # service.ops.observe writes one JSON line per request instead
            # Idle keep-alive connections closed after 5 s; beyond 4096 connections and requests
            # at once, new ones get 503 at once rather than queueing (slow bodies are cut by
            # PLANNER_BODY_TIMEOUT_SECONDS).
            timeout_keep_alive=KEEP_ALIVE_SECONDS,
            limit_concurrency=MAX_CONCURRENCY,
            backlog=MAX_CONCURRENCY,
            timeout_graceful_shutdown=10,
            server_header=False,
        )
    )
    server.run()
    return 0 if server.started else 1


if __name__ == "__main__":
    raise SystemExit(main())

"""``python -m service``: the service under uvicorn on ``PLANNER_HOST``:``PLANNER_PORT``, as
``make run`` and the container start it, logging JSON lines on stdout, with its connection
limits from the settings (``PLANNER_HTTP_PARSER``, ``PLANNER_MAX_HEADER_BYTES``,
``PLANNER_KEEP_ALIVE_SECONDS``, ``PLANNER_MAX_CONNECTIONS``)."""

from __future__ import annotations

import gc
import resource
import socket

import uvicorn

from service.config import Settings
from service.ops.logs import LOG, configure

__all__ = ["FILES_BESIDE_CONNECTIONS", "main", "open_file_limit", "uvicorn_config"]

FILES_BESIDE_CONNECTIONS = 256
"""Open files the process needs besides its connections (the listening socket, Redis, logs,
the numba cache)."""


class _Server(uvicorn.Server):
    async def startup(self, sockets: list[socket.socket] | None = None) -> None:
        await super().startup(sockets=sockets)
        if self.should_exit:  # the lifespan failed, or the port was taken
            return
        from service.main import app  # the module uvicorn loaded, with its lifespan's facts

        bound = [s.getsockname() for server in self.servers for s in server.sockets or ()]
        addresses = [f"http://{a[0]}:{a[1]}" for a in bound if isinstance(a, tuple)]
        fields = {"address": addresses[0] if addresses else None, **app.state.startup}
        # Start-up's objects (modules, the app, the compiled kernels), collected once and then
        # left out of every collection while serving (docs/performance.md, "Garbage
        # collection"): a full collection would walk them all, in some request's answer.
        gc.collect()
        gc.freeze()
        LOG.info("listening", extra={"fields": fields})


def open_file_limit(connections: int) -> tuple[int, int]:
    """The process's open-file limit raised (its soft limit, up to the hard one) to hold
    ``connections`` and :data:`FILES_BESIDE_CONNECTIONS`: ``(limit now, limit needed)``.
    Short of it, connections beyond wait in the listen backlog rather than being answered."""
    needed = connections + FILES_BESIDE_CONNECTIONS
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and soft < needed:
        target = needed if hard == resource.RLIM_INFINITY else min(needed, hard)
        resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
        soft = target
    return soft, needed


def uvicorn_config(
    settings: Settings, log_config: dict[str, object] | None = None
) -> uvicorn.Config:
    """uvicorn's configuration for ``settings``."""
    return uvicorn.Config(
        "service.main:app",
        host=settings.host,
        port=settings.port,
        log_config=log_config,
        access_log=False,  # service.ops.observe writes one JSON line per request instead
        http=settings.http_parser,
        h11_max_incomplete_event_size=settings.max_header_bytes,
        # Idle keep-alive connections are closed; beyond max_connections connections (or
        # requests) at once, uvicorn answers 503 at once. The service's own limit on requests
        # (PLANNER_MAX_REQUESTS, below it) spares /healthz; slow bodies are cut by
        # PLANNER_BODY_TIMEOUT_SECONDS. A request's head has no time limit in uvicorn: the proxy
        # in front bounds it (docker/nginx.conf, client_header_timeout).
        timeout_keep_alive=settings.keep_alive_seconds,
        limit_concurrency=settings.max_connections,
        backlog=min(settings.max_connections, 4096),
        timeout_graceful_shutdown=10,
        server_header=False,
    )


def main() -> int:
    """Serve until stopped (Ctrl-C, SIGTERM); 1 when the service could not start."""
    settings = Settings()
    config = configure(settings.log_level)
    files, needed = open_file_limit(settings.max_connections)
    if files < needed:
        LOG.warning(
            "the open-file limit is below PLANNER_MAX_CONNECTIONS",
            extra={"fields": {"open_files": files, "needed": needed}},
        )
    server = _Server(uvicorn_config(settings, config))
    server.run()
    return 0 if server.started else 1


if __name__ == "__main__":
    raise SystemExit(main())

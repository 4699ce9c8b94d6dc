"""A step's cost through the whole app in-process: ``await app(scope, receive, send)``, no server.

Builds the app (default settings, memory store), uploads a 1024 x 1024 map with walls that make
the way long (``http_steps.serpentine_map``) and plans on it, then serves steps with 10 dynamic
obstacles each to it directly over ASGI: the edge middleware, routing, the body read and
validated, the step, the answer encoded. Prints the median µs a step over rounds of steps, each
round on a fresh plan. Run it on two checkouts to compare them:

    .venv/bin/python benchmarks/asgi_step.py [--steps 2000] [--rounds 7]
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from http_steps import SIZE, serpentine_map

from service.main import create_app


async def run(steps: int, rounds: int) -> list[float]:
    logging.getLogger("service.access").setLevel(logging.WARNING)  # no request lines
    app: Any = create_app()
    rows, start, goal = serpentine_map()
    rng = np.random.default_rng(0)
    async with app.router.lifespan_context(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://bench") as client:
            made = await client.post("/maps", json={"rows": rows})
            body = {"map_id": made.json()["map_id"], "start": start, "goal": goal}
            plans = [
                (await client.post("/plan", json=body)).json()["plan_id"] for _ in range(rounds + 1)
            ]
        sent: list[int] = []

        async def send(message: Any) -> None:
            if message["type"] == "http.response.start":
                sent.append(message["status"])

        per_step = []
        for plan_id in plans:
            bodies = []
            for seq in range(steps):
                cells = rng.integers(1, SIZE - 1, size=(10, 2)).tolist()
                bodies.append(b'{"seq": %d, "dynamic_obstacles": %s}' % (seq, str(cells).encode()))
            scopes = []
            for content in bodies:
                scopes.append(
                    {
                        "type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1",
                        "method": "POST", "scheme": "http", "path": f"/plan/{plan_id}/step",
                        "raw_path": f"/plan/{plan_id}/step".encode(), "root_path": "",
                        "query_string": b"", "server": ("bench", 80),
                        "client": ("127.0.0.1", 1), "state": {},
                        "headers": [
                            (b"host", b"bench"), (b"content-type", b"application/json"),
                            (b"content-length", b"%d" % len(content)),
                        ],
                    }
                )  # fmt: skip
            sent.clear()
            t0 = time.perf_counter()
            for scope, content in zip(scopes, bodies, strict=True):
                message = {"type": "http.request", "body": content, "more_body": False}

                async def receive(message: Any = message) -> Any:
                    return message

                await app(scope, receive, send)
            per_step.append((time.perf_counter() - t0) / steps * 1e6)
            assert sent == [200] * steps, sorted(set(sent))
    return per_step[1:]  # the first round warms up (the wave grows, caches fill)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    per_step = asyncio.run(run(args.steps, args.rounds))
    import service

    print(f"service from {Path(service.__file__).parent}")
    print(
        f"µs a step, in-process over ASGI ({args.rounds} rounds of {args.steps}): median "
        f"{statistics.median(per_step):.1f}, best {min(per_step):.1f}, "
        f"all {' '.join(f'{v:.1f}' for v in per_step)}"
    )


if __name__ == "__main__":
    main()

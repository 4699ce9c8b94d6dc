"""A step's cost through the whole app in-process: ``await app(scope, receive, send)``, no server.

Builds the app (default settings, memory store), uploads a 1024 x 1024 map with walls that make
the way long (``http_steps.serpentine_map``) and plans on it, then serves steps with 10 dynamic
obstacles each to it directly over ASGI: the edge middleware, routing, the body read and
validated, the step, the answer encoded. Prints the median µs a step over rounds of steps, each
round on a fresh plan; beside it, in the same run, the bare FastAPI echo
(``benchmarks/bare_app.py``) served the same bodies the same way, and the step's own work without
ASGI or JSON (``service.resources.plans.step`` on a parsed body): where a step's time goes
between the framework and the planner (docs/performance.md). Run it on two checkouts to compare
them:

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
from bare_app import app as echo_app
from http_steps import SIZE, serpentine_map

from schemas import PlanCreate, StepCreate
from service.main import create_app
from service.resources import plans as plan_steps


def _scope(path: str, content: bytes) -> dict[str, Any]:
    return {
        "type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "POST",
        "scheme": "http", "path": path, "raw_path": path.encode(), "root_path": "",
        "query_string": b"", "server": ("bench", 80), "client": ("127.0.0.1", 1), "state": {},
        "headers": [
            (b"host", b"bench"), (b"content-type", b"application/json"),
            (b"content-length", b"%d" % len(content)),
        ],
    }  # fmt: skip


async def _serve(app: Any, path: str, bodies: list[bytes]) -> float:
    """µs a request: ``bodies`` posted to ``path`` over ASGI, one after the other (all 200)."""
    sent: list[int] = []

    async def send(message: Any) -> None:
        if message["type"] == "http.response.start":
            sent.append(message["status"])

    scopes = [_scope(path, content) for content in bodies]
    t0 = time.perf_counter()
    for scope, content in zip(scopes, bodies, strict=True):
        message = {"type": "http.request", "body": content, "more_body": False}

        async def receive(message: Any = message) -> Any:
            return message

        await app(scope, receive, send)
    elapsed = (time.perf_counter() - t0) / len(bodies) * 1e6
    assert sent == [200] * len(bodies), sorted(set(sent))
    return elapsed


async def run(steps: int, rounds: int) -> dict[str, list[float]]:
    """µs a request, a round each: ``step`` over ASGI, ``echo`` (the bare app, the same bodies
    over ASGI), ``own`` (the step without ASGI or JSON, on a fresh plan of its own)."""
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
        got: dict[str, list[float]] = {"step": [], "echo": [], "own": []}
        for plan_id in plans:
            bodies = []
            for seq in range(steps):
                cells = rng.integers(1, SIZE - 1, size=(10, 2)).tolist()
                bodies.append(b'{"seq": %d, "dynamic_obstacles": %s}' % (seq, str(cells).encode()))
            got["step"].append(await _serve(app, f"/plan/{plan_id}/step", bodies))
            got["echo"].append(await _serve(echo_app, "/echo", bodies))
            own = (await plan_steps.create_plan(app.state.engine, PlanCreate(**body))).plan_id
            parsed = [StepCreate.model_validate_json(b) for b in bodies]
            t0 = time.perf_counter()
            for step in parsed:
                await plan_steps.step(app.state.engine, own, step)
            got["own"].append((time.perf_counter() - t0) / steps * 1e6)
    return {k: v[1:] for k, v in got.items()}  # the first round warms up (waves, caches)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    got = asyncio.run(run(args.steps, args.rounds))
    import service

    print(f"service from {Path(service.__file__).parent}")
    print(f"µs a request, in-process ({args.rounds} rounds of {args.steps}):")
    names = {
        "step": "step over ASGI", "echo": "bare echo over ASGI", "own": "step, no ASGI or JSON"
    }  # fmt: skip
    for key, name in names.items():
        values = got[key]
        print(
            f"  {name}: median {statistics.median(values):.1f}, best {min(values):.1f}, "
            f"all {' '.join(f'{v:.1f}' for v in values)}"
        )


if __name__ == "__main__":
    main()

"""A step on the Redis store is one round trip (docs/redis-store.md): a plain plan's step on a
robot map with live marks, a fleet robot's step on a grid and on a robot map with marks (the
marks a step decides on are the ones its replica last heard, checked by the step's script);
and a fleet robot whose steps alternate between two replicas costs the refused stale copy and
the write, nothing more. Round trips are counted where redis-py sends: one packed send each
(a pipeline is one)."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator
from contextlib import AsyncExitStack, contextmanager
from typing import Any

import httpx
import pytest
from redis.asyncio.connection import AbstractConnection

from service.config import Settings
from service.main import create_app
from tests.service.conftest import RedisServer, running
from tests.service.test_live import BOX, MAP, PLAN, RADIUS, _crosses, _scan

pytestmark = pytest.mark.anyio


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture
async def two(redis_server: RedisServer) -> AsyncIterator[list[httpx.AsyncClient]]:
    """Two replicas (in this process) sharing one Redis."""
    settings = Settings(store_url=redis_server.url, pool_size=1)
    async with AsyncExitStack() as stack:
        clients = []
        for _ in range(2):
            app = create_app(settings)
            await stack.enter_async_context(running(app))
            transport = httpx.ASGITransport(app=app)
            client = httpx.AsyncClient(transport=transport, base_url="http://service")
            clients.append(await stack.enter_async_context(client))
        yield clients


@contextmanager
def round_trips() -> Iterator[list[int]]:
    """Counts what redis-py sends: one packed send is one round trip (a pipeline's commands
    go in one send)."""
    sent: list[int] = []
    send = AbstractConnection.send_packed_command

    async def counted(self: AbstractConnection, command: Any, check_health: bool = True) -> None:
        sent.append(1)
        await send(self, command, check_health)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(AbstractConnection, "send_packed_command", counted)
        yield sent


async def _step(client: httpx.AsyncClient, plan_id: str, **body: Any) -> dict[str, Any]:
    answer = await client.post(f"/plan/{plan_id}/step", json=body)
    assert answer.status_code == 200, answer.text
    return dict(answer.json())


async def _marked(client: httpx.AsyncClient, map_id: str, *, gone: bool = False) -> None:
    """A scan of the box between the robots and their goal, reported to ``client`` (``gone``:
    the box taken away, its marks cleared)."""
    body = {
        "scan": _scan((1.05, 1.45, 0.0), [] if gone else [BOX]),
        "scan_pose": {"x": 1.05, "y": 1.45, "yaw": 0.0},
    }
    answer = await client.post(f"/maps/{map_id}/observations", json=body)
    assert answer.status_code == 200, answer.text
    assert (answer.json()["marks"] == 0) if gone else (answer.json()["marks"] > 5)


async def test_a_plain_step_on_a_robot_map_with_marks_is_one_round_trip(
    two: list[httpx.AsyncClient],
) -> None:
    a, b = two
    map_id = (await a.post("/maps", json=MAP)).json()["map_id"]
    plan_id = (await a.post("/plan", json={"map_id": map_id, **PLAN})).json()["plan_id"]
    assert _crosses((await _step(a, plan_id, seq=0))["poses"], BOX)  # no marks yet
    await _marked(a, map_id)  # the scan's answer carries the marks to replica a
    with round_trips() as sent:
        for seq in range(1, 6):
            answer = await _step(a, plan_id, seq=seq)
            assert seq > 1 or not _crosses(answer["poses"], BOX, margin=RADIUS)
            assert len(sent) == seq  # the step's script only
    await _marked(b, map_id, gone=True)  # the box gone, seen by the other replica
    with round_trips() as sent:
        answer = await _step(a, plan_id, seq=6)
    assert _crosses(answer["poses"], BOX)  # straight on: a's copy of the marks was refused
    assert len(sent) == 2  # refused on the marks, which the refusal carries; then written


async def _fleet(client: httpx.AsyncClient, map_id: str, ends: list[Any]) -> list[str]:
    plans = []
    for start, goal in ends:
        body = {"map_id": map_id, "start": start, "goal": goal, "fleet": "f"}
        answer = await client.post("/plan", json={**body, "robot_radius": RADIUS})
        assert answer.status_code == 201, answer.text
        plans.append(answer.json()["plan_id"])
    return plans


GRID = {"grid": [[0] * 12 for _ in range(6)]}
"""A plain grid: no frame in meters, no marks."""


@pytest.mark.parametrize("robot_map", ["grid", "robot"])
async def test_a_fleet_step_is_one_round_trip(two: list[httpx.AsyncClient], robot_map: str) -> None:
    a, _ = two
    ends: list[tuple[Any, Any]]
    if robot_map == "grid":
        map_id = (await a.post("/maps", json=GRID)).json()["map_id"]
        ends = [([1, 1], [1, 10]), ([4, 10], [4, 1])]
    else:
        map_id = (await a.post("/maps", json=MAP)).json()["map_id"]
        ends = [(PLAN["start"], PLAN["goal"]), ({"x": 5.45, "y": 0.55}, {"x": 0.55, "y": 0.55})]
        await _marked(a, map_id)
    plans = await _fleet(a, map_id, ends)
    for plan_id in plans:  # the fleet solved and read once by this replica
        await _step(a, plan_id, seq=0)
    with round_trips() as sent:
        for seq in range(1, 6):
            for plan_id in plans:
                await _step(a, plan_id, seq=seq)
                assert len(sent) == 1, (seq, plan_id)
                sent.clear()


async def test_a_fleet_robot_stepped_on_two_replicas_in_turn_costs_its_stale_copy_only(
    two: list[httpx.AsyncClient],
) -> None:
    a, b = two
    map_id = (await a.post("/maps", json=MAP)).json()["map_id"]
    await _marked(a, map_id)
    ends = [(PLAN["start"], PLAN["goal"]), ({"x": 5.45, "y": 0.55}, {"x": 0.55, "y": 0.55})]
    mover, other = await _fleet(a, map_id, ends)
    await _step(a, other, seq=0)
    await _step(a, mover, seq=0)
    await _step(b, mover, seq=1)  # b reads the plan, its fleet and the marks: its first
    counts = []
    for seq in range(2, 8):
        with round_trips() as sent:
            answer = await _step((a, b)[seq % 2], mover, seq=seq)
        assert not _crosses(answer["poses"], BOX, margin=RADIUS)
        counts.append(len(sent))
    # Each replica's copy is a step old: refused (one read of the plan, its fleet's progress
    # and its map's marks together), then written.
    assert counts == [2] * 6
    counts = []
    for seq in range(8, 11):  # back on replica a: its copy is stale once, then its own
        with round_trips() as sent:
            await _step(a, mover, seq=seq)
        counts.append(len(sent))
    assert counts == [2, 1, 1]

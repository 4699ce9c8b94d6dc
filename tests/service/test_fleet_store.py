"""The stores keep a fleet's state consistent under concurrent steps: each step claims a cell no
other robot of the fleet holds, decided on the fleet's state; however the steps interleave (one
process, or two replicas on one Redis), no two robots ever hold one cell. Joining and leaving
change the fleet at once with the plan; the fleet goes with its last robot."""

from __future__ import annotations

import asyncio
from typing import Any

import numpy as np
import pytest

import planner
from service.stores import MemoryStore, RedisStore
from service.stores.base import FleetRecord, Store, Update
from service.tenants import TENANT
from tests.service.conftest import RedisServer

pytestmark = pytest.mark.anyio


def _join(plan_id: str) -> Any:
    def apply(fleet: FleetRecord | None) -> FleetRecord:
        fleet = fleet or {"map_id": "m", "radius": 0.0, "next": 0, "robots": {}}
        robot = {"rank": fleet["next"], "cell": [0, 0], "target": [0, 0], "radius": 0.0,
                 "goal": [0, 0], "slot": None}  # fmt: skip
        return {**fleet, "next": fleet["next"] + 1, "robots": {**fleet["robots"], plan_id: robot}}

    return apply


def _claim(plan_id: str) -> Any:
    """A step taking the lowest slot no other robot of the fleet holds, yielding to the event
    loop while it decides (as a real step does when it awaits the pool)."""

    async def decide(record: dict[str, Any], fleet: FleetRecord | None) -> Update[int]:
        assert fleet is not None
        taken = {r["slot"] for k, r in fleet["robots"].items() if k != plan_id}
        slot = min(set(range(64)) - taken)
        await asyncio.sleep(0.001)
        me = {**fleet["robots"][plan_id], "slot": slot}
        state = {**fleet, "robots": {**fleet["robots"], plan_id: me}}
        return Update(slot, {**record, "n": record["n"] + 1}, [(slot, 0)], None, state)

    return decide


MAP = planner.RobotMap(np.zeros((2, 2), dtype=np.int8), planner.MapFrame((2, 2)))
RECORD = {"fleet": "f", "n": 0, "map_id": "m"}
"""A fleet's plan always names its map (the stores check it is still there)."""


async def _race(stores: list[Store], robots: int, rounds: int) -> None:
    plans = [f"p{i}" for i in range(robots)]
    await stores[0].put_map("m", MAP)
    for plan_id in plans:
        await stores[0].put_fleet_plan(plan_id, dict(RECORD), _join(plan_id))
    for r in range(rounds):
        # Every robot steps at once, each on a store of its own in turn (replicas alternate).
        updates = await asyncio.gather(
            *(stores[(i + r) % len(stores)].step_plan(p, _claim(p)) for i, p in enumerate(plans))
        )
        fleet = await stores[0].get_fleet("f")
        assert fleet is not None
        slots = [fleet["robots"][p]["slot"] for p in plans]
        assert len(set(slots)) == robots, slots  # never one slot for two robots
        assert sorted(u.answer for u in updates if u is not None) == sorted(slots)
    for plan_id in plans:
        record = await stores[1 % len(stores)].get_plan(plan_id)
        assert record is not None
        assert record["n"] == rounds
    # Leaving: the fleet goes with its last robot.
    for i, plan_id in enumerate(plans):
        assert await stores[i % len(stores)].delete_plan(plan_id)
        fleet = await stores[0].get_fleet("f")
        left = plans[i + 1 :]
        assert (fleet is None) == (not left)
        if fleet is not None:
            assert sorted(fleet["robots"]) == left


async def test_memory_store_steps_of_a_fleet_never_claim_one_cell() -> None:
    store = MemoryStore(ttl_seconds=60)
    await _race([store], robots=8, rounds=5)
    assert store.lock_count == 0


async def test_two_redis_replicas_steps_of_a_fleet_never_claim_one_cell(
    redis_server: RedisServer,
) -> None:
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        await _race([a, b], robots=8, rounds=5)
        assert a.lock_count == b.lock_count == 0
    finally:
        await a.close()
        await b.close()


async def test_fleets_of_two_tenants_are_two_fleets(redis_server: RedisServer) -> None:
    stores: list[Store] = [
        MemoryStore(ttl_seconds=60),
        RedisStore(redis_server.url, ttl_seconds=60),
    ]
    try:
        for store in stores:
            for tenant in ("a", "b"):
                token = TENANT.set(tenant)
                try:
                    await store.put_map("m", MAP)
                    await store.put_fleet_plan(f"{tenant}1", dict(RECORD), _join(f"{tenant}1"))
                finally:
                    TENANT.reset(token)
            for tenant in ("a", "b"):
                token = TENANT.set(tenant)
                try:
                    fleet = await store.get_fleet("f")
                    assert fleet is not None
                    assert list(fleet["robots"]) == [f"{tenant}1"]
                finally:
                    TENANT.reset(token)
    finally:
        await stores[1].close()


async def test_a_step_decided_on_a_replicas_stale_fleet_decides_again(
    redis_server: RedisServer,
) -> None:
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        await a.put_map("m", MAP)
        for plan_id in ("x", "y"):
            await a.put_fleet_plan(plan_id, dict(RECORD), _join(plan_id))
        await a.step_plan("x", _claim("x"))  # a's copy of the fleet: x holds slot 0
        await b.step_plan("y", _claim("y"))  # b read the fleet: y takes slot 1
        seen: list[FleetRecord] = []
        claim = _claim("x")

        async def spy(record: dict[str, Any], fleet: FleetRecord | None) -> Update[int]:
            assert fleet is not None
            seen.append(fleet)
            update: Update[int] = await claim(record, fleet)
            return update

        # x steps on a again: a's fleet is stale (y moved on b), so it decides twice.
        await a.step_plan("x", spy)
        assert len(seen) == 2
        assert seen[0]["robots"]["y"]["slot"] is None
        assert seen[1]["robots"]["y"]["slot"] == 1
    finally:
        await a.close()
        await b.close()


def _planned(agents: list[str]) -> Any:
    """A step putting the fleet's robots in one joint plan (its ``agents``, in order)."""

    async def decide(record: dict[str, Any], fleet: FleetRecord | None) -> Update[None]:
        assert fleet is not None
        robots = {k: {**r, "agent": agents.index(k)} for k, r in fleet["robots"].items()}
        state = {**fleet, "agents": agents, "robots": robots}
        return Update(None, {**record, "n": record["n"] + 1}, (), None, state)

    return decide


def _progress(plan_id: str, told: int, seen: list[dict[str, int]], *, change: bool) -> Any:
    """A step telling its robot ``told`` moves (its progress), and with ``change`` changing the
    fleet's record too (as a solve does); ``seen`` gets the robots' moves told it decided on."""

    async def decide(record: dict[str, Any], fleet: FleetRecord | None) -> Update[int]:
        assert fleet is not None
        seen.append({k: int(r.get("told", 0)) for k, r in fleet["robots"].items()})
        me = {**fleet["robots"][plan_id], "told": told}
        state = {**fleet, "robots": {**fleet["robots"], plan_id: me}}
        if change:
            state["solve_id"] = f"{plan_id}-{told}"
        return Update(told, {**record, "n": record["n"] + 1}, (), None, state)

    return decide


async def test_robots_progress_on_two_replicas_does_not_outdate_each_other(
    redis_server: RedisServer,
) -> None:
    """Two robots stepping on two replicas, each only its own progress: no step decides twice
    (the fleet's record is not rewritten); each replica knows the other robot's progress as
    its own last write was answered (a step late: a robot then only waits a step longer)."""
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        await a.put_map("m", MAP)
        for plan_id in ("x", "y"):
            await a.put_fleet_plan(plan_id, dict(RECORD), _join(plan_id))
        await a.step_plan("x", _planned(["x", "y"]))  # both in one joint plan
        seen: list[dict[str, int]] = []
        for told in range(1, 6):
            await a.step_plan("x", _progress("x", told, seen, change=False))
            await b.step_plan("y", _progress("y", told, seen, change=False))
        assert len(seen) == 10  # one decision a step
        # Own progress exact, the other robot's as of the replica's last write: a step late.
        assert seen[-2:] == [{"x": 4, "y": 3}, {"x": 4, "y": 4}]
        fleet = await a.get_fleet("f")
        assert fleet is not None
        assert {k: r["told"] for k, r in fleet["robots"].items()} == {"x": 5, "y": 5}
    finally:
        await a.close()
        await b.close()


async def test_a_fleet_change_decided_on_a_robots_stale_progress_decides_again(
    redis_server: RedisServer,
) -> None:
    """A change of the fleet's record (a solve) decided while another robot was told more
    moves on another replica is refused and decided again on that robot's progress: the
    robot may already be on its way through those moves."""
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        await a.put_map("m", MAP)
        for plan_id in ("x", "y"):
            await a.put_fleet_plan(plan_id, dict(RECORD), _join(plan_id))
        seen: list[dict[str, int]] = []
        await a.step_plan("x", _progress("x", 1, seen, change=False))  # a reads y: told 0
        await b.step_plan("y", _progress("y", 3, seen, change=False))  # y told 3 on b
        seen.clear()
        await a.step_plan("x", _progress("x", 2, seen, change=True))
        assert [s["y"] for s in seen] == [0, 3]  # decided again on y's progress
        fleet = await b.get_fleet("f")
        assert fleet is not None
        assert fleet["solve_id"] == "x-2"
        assert {k: r["told"] for k, r in fleet["robots"].items()} == {"x": 2, "y": 3}
    finally:
        await a.close()
        await b.close()


async def test_a_robot_stepping_on_two_replicas_decides_on_its_own_last_progress(
    redis_server: RedisServer,
) -> None:
    """A robot's steps alternating between replicas: each replica's copy of its plan is the
    older one, which a step refuses (as a step's ``seq`` does) and reads again; the step then
    decides on the robot's progress as the other replica left it, never on an older copy (a
    robot told fewer moves than it was may be sent where another is going)."""
    a = RedisStore(redis_server.url, ttl_seconds=60)
    b = RedisStore(redis_server.url, ttl_seconds=60)
    try:
        await a.put_map("m", MAP)
        for plan_id in ("x", "y"):
            await a.put_fleet_plan(plan_id, dict(RECORD), _join(plan_id))
        await a.step_plan("x", _planned(["x", "y"]))
        await b.step_plan("y", _planned(["x", "y"]))  # b has read the fleet too
        own: list[int] = []

        def step(told: int) -> Any:
            async def decide(record: dict[str, Any], fleet: FleetRecord | None) -> Update[int]:
                assert fleet is not None
                if record["n"] != told:  # a stale copy of the plan: refused, read again
                    raise planner.SequenceConflict(f"n {record['n']}", field="seq")
                own.append(int(fleet["robots"]["x"].get("told", 0)))
                me = {**fleet["robots"]["x"], "told": told}
                state = {**fleet, "robots": {**fleet["robots"], "x": me}}
                return Update(told, {**record, "n": record["n"] + 1}, (), None, state)

            return decide

        for told in range(1, 7):
            await (a, b)[told % 2].step_plan("x", step(told))
        assert own == [0, 1, 2, 3, 4, 5]
    finally:
        await a.close()
        await b.close()

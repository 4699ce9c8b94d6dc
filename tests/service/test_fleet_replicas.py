"""A fleet on Redis served by two replicas, each robot's steps alternating between them and the
steps of a tick sent at once, some robots skipping ticks and pausing: no two robots' paths ever
come closer than the sum of their radii (the fleet's state is version-fenced in Redis), and all
arrive (in a room, through a one-lane corridor, between random rooms and corridors)."""

from __future__ import annotations

import asyncio
from pathlib import Path

import httpx

from tests.service.conftest import RedisServer, replicas
from tests.service.test_fleets import F, S, room


def test_a_fleet_on_two_replicas_never_collides(redis_server: RedisServer, tmp_path: Path) -> None:
    ends = (((15, 3), (15, 28)), ((15, 28), (15, 3)), ((3, 15), (28, 15)), ((28, 15), (3, 15)))
    scenario = F.Scenario("cross", room(), 0.25, ends)

    async def main(urls: list[str]) -> list[object]:
        clients = [httpx.AsyncClient(base_url=u, timeout=60, trust_env=False) for u in urls]
        try:
            runs = [
                await F.run(clients, scenario, fleet=f"cross-{seed}", seed=seed, skip=0.2)
                for seed in range(2)
            ]
            # Two robots swapping through a one-lane corridor, and four; random rooms and
            # corridors with robots that skip ticks and pause.
            for per_side in (1, 2):
                corridor = F.corridor_scenario(per_side, 0)
                runs.append(await F.run(clients, corridor, fleet=f"lane-{per_side}", seed=0))
            for seed in range(3):
                rooms = S.random_corridor_scenario(seed)
                runs.append(
                    await F.run(clients, rooms, fleet=f"rooms-{seed}", seed=seed, skip=0.2,
                                pause=0.02)
                )  # fmt: skip
            return runs
        finally:
            for c in clients:
                await c.aclose()

    with replicas(redis_server.url, tmp_path, 2) as started:
        outcomes = asyncio.run(main([r.url for r in started]))
        for outcome in outcomes:
            assert outcome.errors == []  # type: ignore[attr-defined]
            assert outcome.collisions == []  # type: ignore[attr-defined]
            assert outcome.arrived == outcome.robots  # type: ignore[attr-defined]
        # The fleet left Redis with its last plan.
        with httpx.Client(base_url=started[1].url, trust_env=False) as c:
            assert c.get("/fleets/cross-0").status_code == 404


def test_a_fleet_name_used_again_on_another_map_is_a_new_fleet_on_every_replica(
    redis_server: RedisServer, tmp_path: Path
) -> None:
    """A replica that stepped a fleet keeps its copy; the fleet gone and its name taken again on
    another map through the other replica, a step there decides on the new fleet."""
    with replicas(redis_server.url, tmp_path, 2) as (one, two):
        a, b = (httpx.Client(base_url=r.url, trust_env=False, timeout=30) for r in (one, two))
        with a, b:
            ids = []
            lane = F.corridor_scenario(1, 0)  # a map with a passage, then a larger one
            for robot_map, (start, goal) in ((lane.robot_map, lane.robots[0]),
                                             (room(side=60), ((55, 5), (5, 55)))):  # fmt: skip
                map_id = a.post("/maps", json=F.map_body(robot_map)).json()["map_id"]
                body = {"map_id": map_id, "start": list(start), "goal": list(goal),
                        "robot_radius": 0.325, "fleet": "again"}  # fmt: skip
                made = a.post("/plan", json=body)
                assert made.status_code == 201, made.text
                ids.append(made.json()["plan_id"])
                assert b.post(f"/plan/{ids[-1]}/step", json={}).status_code == 200
                assert a.delete(f"/plan/{ids[-1]}").status_code == 204
            assert a.get("/fleets/again").status_code == 404

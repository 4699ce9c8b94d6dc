"""Fleets (docs/fleets.md): plans of one fleet are solved together on a roadmap and executed in
order: whatever the order, pace and pauses of their steps, no two robots come closer than their
radii and every robot arrives; a waiting robot names whom it waits for; a silent robot is
planned around; fleets are per map and per tenant."""

from __future__ import annotations

import asyncio
from typing import Any

import httpx
import numpy as np
import pytest
from pydantic import SecretStr

import planner
import planner.fleets
from service.config import Settings
from service.main import create_app
from service.resources import fleets
from tests.scripts import load_benchmark
from tests.service.conftest import running

F = load_benchmark("fleet")
S = load_benchmark("fleet_scenarios")
pytestmark = pytest.mark.anyio
SETTINGS = Settings(pool_size=1)


def room(side: int = 30, resolution: float = 0.1) -> planner.RobotMap:
    """An empty square room, walls one cell thick."""
    occ = np.pad(np.zeros((side, side), np.int8), 1, constant_values=100)
    return planner.RobotMap(occ, planner.MapFrame(occ.shape, resolution, (0.0, 0.0, 0.0)))


@pytest.fixture
async def client() -> Any:
    app = create_app(SETTINGS)
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            yield c


async def _map(client: httpx.AsyncClient, robot_map: planner.RobotMap) -> str:
    answer = await client.post("/maps", json=F.map_body(robot_map))
    assert answer.status_code in (200, 201), answer.text
    return str(answer.json()["map_id"])


async def _plan(
    client: httpx.AsyncClient, map_id: str, start: list[int], goal: list[int], **extra: Any
) -> httpx.Response:
    body = {"map_id": map_id, "start": start, "goal": goal, "robot_radius": 0.25} | extra
    return await client.post("/plan", json=body)


async def test_robots_crossing_a_room_never_collide_and_all_arrive(
    client: httpx.AsyncClient,
) -> None:
    # Four robots crossing through the middle at once, two pairs head-on. In the tick orders of
    # seeds 8, 43 and 64 two of them, blocking each other, searched their way round at once, the
    # same way, met again and did so for ever, until the one of lower priority went first.
    ends = (((15, 3), (15, 28)), ((15, 28), (15, 3)), ((3, 15), (28, 15)), ((28, 15), (3, 15)))
    scenario = F.Scenario("cross", room(), 0.25, ends)
    for seed in (0, 1, 8, 43, 64):
        outcome = await F.run([client], scenario, fleet=f"cross-{seed}", seed=seed)
        assert outcome.errors == []
        assert outcome.collisions == []
        assert outcome.arrived == 4, outcome


@pytest.mark.parametrize(("per_side", "seeds"), [(1, (0, 1, 2)), (2, (0, 1, 24))])
async def test_robots_swapping_through_a_one_lane_corridor_take_turns(
    client: httpx.AsyncClient, per_side: int, seeds: tuple[int, ...]
) -> None:
    for seed in seeds:
        scenario = F.corridor_scenario(per_side, seed)
        outcome = await F.run([client], scenario, fleet=f"corridor-{seed}", seed=seed, skip=0.2)
        assert outcome.errors == []
        assert outcome.collisions == []
        assert outcome.arrived == 2 * per_side, outcome


@pytest.mark.parametrize("seed", range(12))
async def test_random_rooms_and_corridors_with_skips_and_pauses(
    client: httpx.AsyncClient, seed: int
) -> None:
    """Rooms of random sizes, a corridor 1-4 m long and 2r + 0.05 m to 4r wide, 1-4 robots a
    side; robots skip ticks and fall silent for a while."""
    scenario = S.random_corridor_scenario(seed)
    outcome = await F.run(
        [client], scenario, fleet=f"rooms-{seed}", seed=seed, skip=0.2, pause=0.02
    )
    assert outcome.errors == []
    assert outcome.collisions == []
    assert outcome.arrived == outcome.robots, outcome


async def test_a_waiting_robot_names_whom_it_waits_for(client: httpx.AsyncClient) -> None:
    scenario = F.corridor_scenario(1, 0)
    map_id = await _map(client, scenario.robot_map)
    (a_start, a_goal), (b_start, b_goal) = scenario.robots
    a = (await _plan(client, map_id, list(a_start), list(a_goal), fleet="d",
                     robot_radius=0.325)).json()["plan_id"]  # fmt: skip
    b = (await _plan(client, map_id, list(b_start), list(b_goal), fleet="d",
                     robot_radius=0.325)).json()["plan_id"]  # fmt: skip
    fleet = (await client.get("/fleets/d")).json()
    assert fleet["robot_radius"] == 0.325
    assert fleet["solve"]["status"] == "solved"  # solved as each robot joined
    assert fleet["solve"]["agents"] == 2
    assert fleet["roadmap"]["nodes"] > 10
    waited_for: set[str] = set()
    for seq in range(200):
        for plan_id in (a, b):
            step = (await client.post(f"/plan/{plan_id}/step", json={"seq": seq})).json()
            if step["status"] == "waiting":
                assert step["waiting_for"] in (a, b)
                assert step["waiting_for"] != plan_id
                waited_for.add(step["waiting_for"])
        fleet = (await client.get("/fleets/d")).json()
        assert fleet["solve"]["status"] == "solved"
        assert fleet["solve"]["sum_of_costs"] >= fleet["solve"]["lower_bound"] > 0
        for robot in fleet["robots"]:
            assert robot["moves_done"] <= robot["moves_total"]
            assert len(robot["remaining"]) == len(robot["remaining_xy"])
        if all(r["status"] == "arrived" for r in fleet["robots"]):
            break
    assert all(r["status"] == "arrived" for r in fleet["robots"])
    assert waited_for  # one waited for the other


async def test_a_silent_robot_is_planned_around_after_its_lease() -> None:
    """A robot that stops stepping in the corridor: past the lease the other is solved again
    around it (it stands where it last was) and gets by, or waits naming it when it cannot."""
    app = create_app(SETTINGS.model_copy(update={"fleet_lease_seconds": 0.3}))
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://s") as client:
            map_id = await _map(client, room(60))
            silent = (await _plan(client, map_id, [30, 30], [5, 5], fleet="f")).json()["plan_id"]
            mover = (await _plan(client, map_id, [30, 5], [30, 55], fleet="f")).json()["plan_id"]
            assert (await client.post(f"/plan/{silent}/step", json={})).status_code == 200
            await asyncio.sleep(0.4)
            answer: dict[str, Any] = {}
            for _ in range(60):
                answer = (await client.post(f"/plan/{mover}/step", json={})).json()
                if answer["status"] == "arrived":
                    break
            assert answer["status"] == "arrived"
            fleet = (await client.get("/fleets/f")).json()
            robots = {r["plan_id"]: r for r in fleet["robots"]}
            assert robots[silent]["parked"] is True
            assert fleet["solve"]["agents"] == 1
            # It steps again: it rejoins.
            assert (await client.post(f"/plan/{silent}/step", json={})).status_code == 200
            fleet = (await client.get("/fleets/f")).json()
            assert not any(r["parked"] for r in fleet["robots"])
            assert fleet["solve"]["agents"] == 2


async def test_robots_created_head_on_inside_a_corridor_never_deadlock(
    client: httpx.AsyncClient,
) -> None:
    m = S.corridor_map(resolution=0.1, lane_m=0.8, length_m=3.0, room_m=4.0)
    row = 20  # the lane's middle row
    scenario = F.Scenario("inside", m, 0.325, (((row, 45), (row, 70)), ((row, 52), (row, 10))))
    for seed in range(3):
        outcome = await F.run([client], scenario, fleet=f"inside-{seed}", seed=seed, skip=0.3)
        assert outcome.errors == []
        assert outcome.collisions == []
        assert outcome.arrived == 2, outcome


async def test_goals_taken_and_fleets_too_big_are_refused(client: httpx.AsyncClient) -> None:
    map_id = await _map(client, room())
    assert (await _plan(client, map_id, [15, 3], [15, 21], fleet="f")).status_code == 201
    taken = await _plan(client, map_id, [5, 3], [15, 22], fleet="f")
    assert taken.status_code == 422
    assert taken.json()["code"] == "FLEET_GOAL_TAKEN"
    assert taken.json()["field"] == "goal"
    bigger = await _plan(client, map_id, [8, 8], [8, 22], fleet="f", robot_radius=0.3)
    assert bigger.status_code == 422
    assert bigger.json()["code"] == "FLEET_RADIUS"


async def test_without_a_fleet_robots_ignore_each_other(client: httpx.AsyncClient) -> None:
    """The control: the same head-on pair without ``fleet`` do meet (what fleets prevent)."""
    map_id = await _map(client, room())
    a = (await _plan(client, map_id, [15, 3], [15, 28])).json()["plan_id"]
    b = (await _plan(client, map_id, [15, 28], [15, 3])).json()["plan_id"]
    met = False
    for seq in range(40):
        pa = (await client.post(f"/plan/{a}/step", json={"seq": seq})).json()["position"]
        pb = (await client.post(f"/plan/{b}/step", json={"seq": seq})).json()["position"]
        met |= (pa[0] - pb[0]) ** 2 + (pa[1] - pb[1]) ** 2 < 5**2
    assert met


async def test_a_fleet_builds_its_roadmap_when_its_plan_is_made(
    client: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Built in the plan's creation: the fleet's first step does not wait for it.
    built: list[float] = []
    build = planner.fleets.build_roadmap

    def counted(analysis: planner.Analysis, *, radius: float, wide: bool) -> Any:
        built.append(radius)
        return build(analysis, radius=radius, wide=wide)

    monkeypatch.setattr(fleets, "build_roadmap", counted)
    map_id = await _map(client, room())
    made = await _plan(client, map_id, [15, 3], [15, 20], fleet="f")
    assert made.status_code == 201, made.text
    assert built == [0.25]
    assert (await client.post(f"/plan/{made.json()['plan_id']}/step", json={})).status_code == 200
    assert (await _plan(client, map_id, [5, 3], [5, 20], fleet="f")).status_code == 201
    assert built == [0.25]  # then kept in the analysis cache


async def test_a_robot_that_never_stepped_counts_at_its_start(client: httpx.AsyncClient) -> None:
    map_id = await _map(client, room())
    made = await _plan(client, map_id, [15, 15], [5, 5], fleet="f")  # never steps
    assert made.status_code == 201, made.text
    mover = (await _plan(client, map_id, [15, 3], [15, 28], fleet="f")).json()["plan_id"]
    for seq in range(80):
        r, c = (await client.post(f"/plan/{mover}/step", json={"seq": seq})).json()["position"]
        assert (r - 15) ** 2 + (c - 15) ** 2 > 5**2


async def test_fleet_map_mismatch_and_taken_start_are_refused(client: httpx.AsyncClient) -> None:
    one, other = await _map(client, room()), await _map(client, room(side=20))
    assert (await _plan(client, one, [5, 5], [20, 20], fleet="f")).status_code == 201
    wrong = await _plan(client, other, [5, 5], [10, 10], fleet="f")
    assert wrong.status_code == 422
    assert wrong.json()["code"] == "FLEET_MAP_MISMATCH"
    assert "FLEET_MAP_MISMATCH" in wrong.json()["detail"]
    taken = await _plan(client, one, [6, 7], [20, 5], fleet="f")  # 0.22 m from the other
    assert taken.status_code == 422
    assert taken.json()["code"] == "FLEET_START_TAKEN"
    # The same with the map upload.
    body = {**F.map_body(room(side=20)), "start": [5, 5], "goal": [10, 10], "fleet": "f"}
    assert (await client.post("/maps", json=body)).json()["code"] == "FLEET_MAP_MISMATCH"
    # Another fleet on the other map is another fleet.
    assert (await _plan(client, other, [5, 5], [10, 10], fleet="g")).status_code == 201


@pytest.mark.parametrize("name", ["", "a" * 65, "has space", "slash/", "ünï", 7, None])
async def test_bad_fleet_names_are_refused(client: httpx.AsyncClient, name: Any) -> None:
    map_id = await _map(client, room())
    answer = await _plan(client, map_id, [5, 5], [20, 20], fleet=name)
    if name is None:
        assert answer.status_code == 201
        return
    assert answer.status_code == 422
    assert "fleet" in answer.text
    if isinstance(name, str) and name and "/" not in name:
        assert (await client.get(f"/fleets/{name}")).status_code == 422


async def test_two_tenants_fleets_of_one_name_never_see_each_other() -> None:
    settings = SETTINGS.model_copy(update={"api_keys": SecretStr("key-a,key-b")})
    app = create_app(settings)
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        clients = [
            httpx.AsyncClient(transport=transport, base_url="http://s", headers={"X-API-Key": k})
            for k in ("key-a", "key-b")
        ]
        a, b = clients
        try:
            map_a, map_b = await _map(a, room()), await _map(b, room())
            assert map_a == map_b  # the same map, stored once per tenant
            pa = (await _plan(a, map_a, [15, 3], [15, 28], fleet="f")).json()["plan_id"]
            # The same start in the other tenant's fleet "f": not taken there.
            made = await _plan(b, map_b, [15, 3], [15, 28], fleet="f")
            assert made.status_code == 201, made.text
            pb = made.json()["plan_id"]
            assert [r["plan_id"] for r in (await a.get("/fleets/f")).json()["robots"]] == [pa]
            assert [r["plan_id"] for r in (await b.get("/fleets/f")).json()["robots"]] == [pb]
            for seq in range(30):  # both drive the same way, through each other's cells
                sa = (await a.post(f"/plan/{pa}/step", json={"seq": seq})).json()
                sb = (await b.post(f"/plan/{pb}/step", json={"seq": seq})).json()
                assert sa["position"] == sb["position"]
            assert (await b.get(f"/plan/{pa}")).status_code == 404
        finally:
            for c in clients:
                await c.aclose()


async def test_concurrent_steps_never_assign_one_cell(client: httpx.AsyncClient) -> None:
    """Eight robots in a small room, all stepped at once every tick, crowding its middle."""
    rng = np.random.default_rng(3)
    cells = [(r, c) for r in range(2, 18, 4) for c in (2, 17)]
    goals = [cells[i] for i in rng.permutation(len(cells))]
    scenario = F.Scenario("crowd", room(side=20), 0.15, tuple(zip(cells, goals, strict=True)))
    outcome = await F.run([client], scenario, fleet="crowd", seed=3, max_ticks=120)
    assert outcome.errors == []
    assert outcome.collisions == []
    assert outcome.ticks == 120 or outcome.arrived == 8


async def test_a_replayed_step_answers_the_same_and_moves_nobody(client: httpx.AsyncClient) -> None:
    map_id = await _map(client, room())
    a = (await _plan(client, map_id, [15, 3], [15, 28], fleet="f")).json()["plan_id"]
    first = (await client.post(f"/plan/{a}/step", json={"seq": 0})).json()
    again = (await client.post(f"/plan/{a}/step", json={"seq": 0})).json()
    assert first == again
    fleet = (await client.get("/fleets/f")).json()
    assert fleet["robots"][0]["position"] == first["position"]
    assert fleet["robots"][0]["previous"] == first["previous"]


def test_store_keeps_no_lock_after_fleet_steps() -> None:
    async def main() -> None:
        app = create_app(SETTINGS)
        async with running(app):
            transport = httpx.ASGITransport(app=app)
            async with httpx.AsyncClient(transport=transport, base_url="http://s") as c:
                scenario = F.Scenario("cross", room(), 0.25, (((15, 3), (15, 28)),))
                await F.run([c], scenario, fleet="x", seed=0)
            assert app.state.engine.store.lock_count == 0

    asyncio.run(main())


async def test_a_step_never_writes_over_another_maps_fleet_of_its_name() -> None:
    """A plan whose fleet was gone while it lived, the name since taken by a fleet on another
    map: its step is a 422 FLEET_MAP_MISMATCH saying what to do, and the other map's fleet is
    left as it was (not replaced by a new fleet on the plan's map)."""
    app = create_app(SETTINGS)
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as client:
            one, two = await _map(client, room(20)), await _map(client, room(24))
            made = await _plan(client, one, [3, 3], [15, 15], fleet="reused")
            assert made.status_code == 201, made.text
            plan_id = made.json()["plan_id"]
            store = app.state.engine.store
            other = {"map_id": two, "radius": 0.25, "params": {}, "next": 0, "robots": {}}
            store._fleets["reused"] = other  # the name taken again on map two
            step = await client.post(f"/plan/{plan_id}/step", json={})
            assert step.status_code == 422, step.text
            assert step.json()["code"] == "FLEET_MAP_MISMATCH"
            assert "delete the plan" in step.json()["detail"]
            assert store._fleets["reused"] is other

"""The service's goal waves: resumable, shared by the plans of a goal, charged to the cache as
they grow, rebuilt after an eviction; steps that may search go to the step workers. Every
answer is checked against a session over the whole-map wave (``planner.plan(..., whole=True)``)."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import httpx
import numpy as np
import pytest
from fastapi import FastAPI

import planner
from service.config import Settings
from service.work.engine import Engine
from tests.service.conftest import random_map

pytestmark = pytest.mark.anyio

SIZE = 512
START, GOAL = (250, 250), (270, 280)


@pytest.fixture
def settings() -> Settings:
    return Settings(pool_size=2)


@pytest.fixture(scope="module")
def grid() -> np.ndarray:
    g = random_map(SIZE, SIZE, 0.2, seed=7)
    g[START] = g[GOAL] = g[260, 266] = g[281, 294] = 0
    return g


def engine_of(app: FastAPI) -> Engine:
    engine = app.state.engine
    assert isinstance(engine, Engine)
    return engine


def cached_waves(engine: Engine) -> list[tuple[Any, planner.Wave, int]]:
    """The cache's waves: (key, wave, the bytes the cache charges for it)."""
    with engine.cache._lock:
        entries = list(engine.cache._entries.items())
    return [(k, v, size) for k, (v, size, _) in entries if isinstance(k, tuple) and k[0] == "wave"]


async def upload_and_plan(
    client: httpx.AsyncClient, grid: np.ndarray, start: Any, goal: Any, **extra: Any
) -> tuple[str, str]:
    r = await client.post("/maps", json={"grid": grid.tolist()})
    assert r.status_code in (200, 201), r.text
    map_id = r.json()["map_id"]
    body = {"map_id": map_id, "start": list(start), "goal": list(goal), **extra}
    r = await client.post("/plan", json=body)
    assert r.status_code == 201, r.text
    return map_id, r.json()["plan_id"]


def reference(grid: np.ndarray, start: Any, goal: Any, **params: Any) -> planner.Session:
    """The same plan over the whole-map wave, as the service planned before waves resumed."""
    p = planner.plan(planner.grid_map(grid), start, goal, whole=True, **params)
    assert not isinstance(p.wave, planner.ResumableWave)
    return planner.Session(p)


def episode(
    grid: np.ndarray, seed: int, steps: int, strays: float = 0.1, reach: int = 40
) -> list[dict[str, Any]]:
    """Seeded step bodies: random dynamic obstacles near the robot's way, now and then a stray
    (a ``position`` reported off the path, up to 40 cells away)."""
    rng = np.random.default_rng(seed)
    free = np.argwhere(grid == 0)
    near = free[(np.abs(free - np.array(START)).max(axis=1) < reach)]
    bodies = []
    for _ in range(steps):
        body: dict[str, Any] = {}
        if rng.random() < 0.5:
            body["dynamic_obstacles"] = near[rng.random(len(near)) < 0.02].tolist()
        if rng.random() < strays:
            body["position"] = near[rng.integers(len(near))].tolist()
        bodies.append(body)
    return bodies


def ahead(session: planner.Session, rng: np.random.Generator) -> dict[str, Any]:
    """A step body that blocks the robot's way: obstacles two cells ahead of it (towards the
    goal), which with the default margin leave it no move forward; now and then a stray."""
    r, c = session.state.position
    gr, gc = session.plan.goal
    H, W = session.plan.analysis.shape
    wall = [
        [r + dr, c + dc]
        for dr in range(-2, 3)
        for dc in range(-2, 3)
        if max(abs(dr), abs(dc)) == 2
        and dr * (gr - r) + dc * (gc - c) > 0
        and 0 <= r + dr < H
        and 0 <= c + dc < W
    ]
    body: dict[str, Any] = {"dynamic_obstacles": wall}
    if rng.random() < 0.1:
        body["position"] = free_near(np.asarray(session.plan.analysis.grid), r + 9, c - 7)
    return body


def free_near(grid: np.ndarray, r: int, c: int) -> list[int]:
    """The free cell nearest (r, c), as JSON takes it."""
    free = np.argwhere(grid == 0)
    cell: list[int] = free[np.abs(free - np.array([r, c])).sum(axis=1).argmin()].tolist()
    return cell


def wide_cost(grid_clean: np.ndarray, cells: list[Any], diagonal: float) -> float:
    rc = np.array(cells)
    steps = np.abs(np.diff(rc, axis=0)).sum(axis=1)
    return float((np.where(steps == 2, diagonal, 1.0) + grid_clean[rc[1:, 0], rc[1:, 1]]).sum())


def compare(
    answer: dict[str, Any], ref: planner.Step, ref_session: planner.Session, detour: list[int]
) -> bool:
    """Whether the service's step and the reference's agree; False (after checking that the
    two took detours of one cost, the only freedom left) when they part."""
    if answer["position"] != list(ref.position):
        assert answer["status"] == ref.status == "replanned", (answer, ref)
        plan = ref_session.plan
        W = plan.analysis.shape[1]
        ours = [answer["previous"], answer["position"], *(divmod(x, W) for x in detour)]
        theirs = [ref.previous, ref.position, *(divmod(x, W) for x in ref_session.state.detour)]
        clean = plan.analysis.clean
        d = plan.params.diagonal_cost
        assert wide_cost(clean, ours, d) == pytest.approx(wide_cost(clean, theirs, d), rel=1e-9)
        return False
    if answer["status"] != ref.status and "replanned" in (answer["status"], ref.status):
        # Detours of one cost may differ in their cells (and a resumable wave's hands over
        # where it has settled): the route ahead of one is cut where the other's is not.
        assert answer["move"] == ref.move
        return False
    assert (answer["move"], answer["status"]) == (ref.move, ref.status)
    assert answer["arc_cost"] == pytest.approx(ref.arc_cost, rel=1e-12, abs=1e-12)
    assert answer["path_length"] == pytest.approx(ref.path_length, rel=1e-12)
    if ref.remaining is None:
        assert answer["remaining"] is None
    else:
        assert answer["remaining"] == pytest.approx(ref.remaining, rel=1e-12)
    return True


async def test_a_near_plan_caches_a_small_resumable_wave_charged_as_it_grows(
    app: FastAPI, client: httpx.AsyncClient, grid: np.ndarray
) -> None:
    _, plan_id = await upload_and_plan(client, grid, START, GOAL)
    engine = engine_of(app)
    (_, wave, charged), *others = cached_waves(engine)
    assert not others
    assert isinstance(wave, planner.ResumableWave)
    assert wave.resumable
    assert wave.nbytes < 0.1 * 17 * grid.size  # the whole-map wave: 17 bytes a cell
    assert charged == wave.nbytes  # measured again after the plan's walk grew it
    before = wave.nbytes
    far = free_near(grid, 120, 400)
    r = await client.post(f"/plan/{plan_id}/step", json={"position": far})
    assert r.status_code == 200, r.text
    assert wave.nbytes > before  # the search resumed from the stray
    assert cached_waves(engine)[0][2] == wave.nbytes
    assert engine.cache.bytes == sum(size for _, (_, size, _) in engine.cache._entries.items())


async def test_steps_that_stray_and_detour_match_a_whole_map_wave(
    client: httpx.AsyncClient, grid: np.ndarray, app: FastAPI
) -> None:
    compared = strays = replans = 0
    for seed in range(4):
        goal = (GOAL[0] + seed, GOAL[1] - 3 * seed)
        if grid[goal]:
            continue
        _, plan_id = await upload_and_plan(client, grid, START, goal, params={"patience": 1})
        ref = reference(grid, START, goal, patience=1)
        rng = np.random.default_rng(seed)
        for seq in range(60):
            body = ahead(ref, rng) if rng.random() < 0.6 else {}
            r = await client.post(f"/plan/{plan_id}/step", json={**body, "seq": seq})
            assert r.status_code == 200, r.text
            answer = r.json()
            want = ref.step(body.get("dynamic_obstacles", []), position=body.get("position"))
            record = await engine_of(app).store.get_plan(plan_id)
            assert record is not None
            if not compare(answer, want, ref, record["state"]["detour"]):
                break
            compared += 1
            strays += "position" in body
            replans += want.status == "replanned"
            if want.status == "arrived":
                break
    assert compared >= 40
    assert strays >= 2
    assert replans >= 1


async def test_an_evicted_wave_is_rebuilt_and_the_plan_steps_on(
    app: FastAPI, client: httpx.AsyncClient, grid: np.ndarray
) -> None:
    engine = engine_of(app)
    _, plan_id = await upload_and_plan(client, grid, START, GOAL, params={"patience": 1})
    ref = reference(grid, START, GOAL, patience=1)
    bodies = episode(grid, 11, 30)
    for seq, body in enumerate(bodies):
        if seq % 10 == 5:  # evicted mid-episode, as a full cache would
            (key, old, _), *_ = cached_waves(engine)
            engine.cache.discard(key)
            assert not any(p.wave is old for p, _ in engine._plans.values())
        r = await client.post(f"/plan/{plan_id}/step", json={**body, "seq": seq})
        assert r.status_code == 200, r.text
        want = ref.step(body.get("dynamic_obstacles", []), position=body.get("position"))
        record = await engine.store.get_plan(plan_id)
        assert record is not None
        if not compare(r.json(), want, ref, record["state"]["detour"]):
            break
        if seq % 10 == 5:
            (_, new, _), *_ = cached_waves(engine)
            assert new is not old  # rebuilt on demand
    assert (await client.get(f"/plan/{plan_id}")).status_code == 200


async def test_a_route_whose_legs_share_a_wave_is_forgotten_once(
    app: FastAPI, client: httpx.AsyncClient
) -> None:
    """Evicting a wave that two legs (and the route itself) read drops the route's plan from the
    memo once: it was deleted once per leg, a ``KeyError`` inside the cache's eviction."""
    engine = engine_of(app)
    free = np.zeros((40, 40), dtype=np.uint8)
    r = await client.post("/maps", json={"grid": free.tolist()})
    body = {"map_id": r.json()["map_id"], "start": [0, 0], "goal": [30, 5]}
    r = await client.post("/plan", json={**body, "waypoints": [[30, 5], [5, 30]] * 2})
    assert r.status_code == 201, r.text
    plan_id = r.json()["plan_id"]
    assert len(engine._plans) == 1
    ((route, _),) = engine._plans.values()
    assert route.route is not None
    shared = route.wave  # the goal's: legs 1, 3 and 5 and the route's own
    assert sum(leg.wave is shared for leg in route.route.legs) == 3
    (key,) = [k for k, w, _ in cached_waves(engine) if w is shared]
    engine._forget(key, shared)
    assert not engine._plans
    engine._remember_plan(("again",), body["map_id"], route)
    engine._forget(("analysis",), route.analysis)  # every leg's
    assert not engine._plans
    r = await client.post(f"/plan/{plan_id}/step", json={})  # rebuilt over the cache's waves
    assert r.status_code == 200, r.text


async def test_a_step_that_must_search_runs_on_a_step_worker(
    app: FastAPI, client: httpx.AsyncClient, grid: np.ndarray, monkeypatch: pytest.MonkeyPatch
) -> None:
    engine = engine_of(app)
    _, plan_id = await upload_and_plan(client, grid, START, GOAL)
    offloaded: list[Any] = []
    run_step = engine.pool.run_step

    async def counting(fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Any:
        offloaded.append(kwargs.get("position"))
        return await run_step(fn, *args, **kwargs)

    monkeypatch.setattr(engine.pool, "run_step", counting)
    r = await client.post(f"/plan/{plan_id}/step", json={})  # along the plan: all settled
    assert r.status_code == 200
    assert offloaded == []
    far = free_near(grid, 60, 60)
    r = await client.post(f"/plan/{plan_id}/step", json={"position": far})
    assert r.status_code == 200
    assert offloaded == [far]  # a stray into unsettled cells: the search resumes off the loop
    r = await client.post(f"/plan/{plan_id}/step", json={})  # settled now, around the stray
    assert r.status_code == 200
    assert offloaded == [far]


async def test_concurrent_steps_of_plans_sharing_a_wave_match_sequential_ones(
    app: FastAPI, client: httpx.AsyncClient, grid: np.ndarray
) -> None:
    engine = engine_of(app)
    starts = [(260, 266), (281, 294)]  # near the goal: the wave stays resumable
    for start in starts:
        assert grid[start] == 0
    ids = [
        # Unbounded detours: both plans keep the preset's weights, so share the goal's wave.
        (await upload_and_plan(client, grid, s, GOAL, params={"patience": 1, "max_detour": 100}))[1]
        for s in starts
    ]
    records = [await engine.store.get_plan(i) for i in ids]
    plans = [await engine.plan_of(rec) for rec in records if rec is not None]
    assert plans[0].wave is plans[1].wave  # one goal, one wave
    shared = plans[0].wave
    assert isinstance(shared, planner.ResumableWave)
    shared.budget = shared.probe = grid.size  # resumed by both threads, never handed over
    assert len(cached_waves(engine)) == 1
    sessions = [planner.Session(p) for p in plans]
    refs = [reference(grid, s, GOAL, patience=1, max_detour=100) for s in starts]
    # A stray at every other step: both threads resume the one search, often at once.
    scripts = [episode(grid, 20 + i, 60, strays=0.5, reach=200) for i in range(2)]
    barrier = threading.Barrier(2)
    answers: list[list[tuple[dict[str, Any], list[int]]]] = [[], []]
    errors: list[BaseException] = []

    def run(i: int) -> None:
        try:
            for body in scripts[i]:
                barrier.wait(timeout=60)
                obstacles, position = body.get("dynamic_obstacles", []), body.get("position")
                step = sessions[i].step(obstacles, position=position)
                answers[i].append((step.as_dict(), list(sessions[i].state.detour)))
        except BaseException as exc:  # reported below, in the test's thread
            errors.append(exc)
            barrier.abort()

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=300)
    assert not errors
    compared = 0
    for i in range(2):
        assert len(answers[i]) == len(scripts[i])
        for (answer, detour), body in zip(answers[i], scripts[i], strict=True):
            want = refs[i].step(body.get("dynamic_obstacles", []), position=body.get("position"))
            if not compare(answer, want, refs[i], detour):
                break
            compared += 1
    assert compared >= 40

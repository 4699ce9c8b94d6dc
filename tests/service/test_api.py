"""Every endpoint of shared/API.md over httpx, and the rules the contract states."""

from __future__ import annotations

import asyncio
import hashlib
import itertools

import httpx
import numpy as np
import orjson
import pytest
from fastapi import FastAPI

import planner
import schemas
from service.stores import MemoryStore

pytestmark = pytest.mark.anyio

ROWS = ["......", ".@@...", "......", "...@..", "......"]
GRID = [[1 if ch == "@" else 0 for ch in row] for row in ROWS]


async def test_same_map_same_id_whichever_encoding(client: httpx.AsyncClient) -> None:
    first = await client.post("/maps", json={"rows": ROWS})
    again = await client.post("/maps", json={"grid": GRID})
    assert (first.status_code, again.status_code) == (201, 200)
    body = first.json()
    assert again.json() == body
    expected = hashlib.sha256(b"5x6:" + np.array(GRID, dtype=np.uint8).tobytes()).hexdigest()
    assert body == {
        "map_id": expected, "height": 5, "width": 6, "free_cells": 27, "plan": None, "zones": None,
        "occupied_cells": 3, "unknown_cells": 0, "resolution": 1.0, "origin": [0.0, 0.0, 0.0],
    }  # fmt: skip
    shown = await client.get(f"/maps/{expected}")
    assert shown.status_code == 200
    assert shown.json() == body


async def test_moving_ai_letters(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={"rows": [".GS", "@TO", "W.."]})
    assert r.json()["free_cells"] == 5
    same = await client.post("/maps", json={"grid": [[0, 0, 0], [1, 1, 1], [1, 0, 0]]})
    assert same.json()["map_id"] == r.json()["map_id"]


async def test_plan_matches_the_planner(client: httpx.AsyncClient) -> None:
    map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
    body = {"map_id": map_id, "start": [0, 0], "goal": [4, 5], "preset": "wfs-mmas",
            "params": {"alpha": 4}}  # fmt: skip
    r = await client.post("/plan", json=body)
    assert r.status_code == 201
    got = r.json()
    want = planner.plan(GRID, [0, 0], [4, 5], preset="wfs-mmas", alpha=4)
    assert got["preview"]["path"] == want.path.tolist()
    assert got["preview"]["length"] == pytest.approx(want.length)
    assert got["params"] == want.params.as_dict()
    assert (got["status"], got["position"], got["preset"]) == ("ready", [0, 0], "wfs-mmas")
    assert got["analysis"]["cache_hit"] is False
    assert got["analysis"]["gates"] == want.gates
    again = (await client.post("/plan", json=body)).json()
    assert again["analysis"]["cache_hit"] is True
    assert again["plan_id"] != got["plan_id"]


async def test_allow_narrow_maps_onto_the_planner_parameter(client: httpx.AsyncClient) -> None:
    corridor = ["........", "........", "@@@.@@@@", "........", "........"]
    map_id = (await client.post("/maps", json={"rows": corridor})).json()["map_id"]
    body = {"map_id": map_id, "start": [0, 3], "goal": [4, 3]}
    narrow = (await client.post("/plan", json=body)).json()
    assert narrow["analysis"]["narrow_fallback"] is True
    assert narrow["params"]["allow_narrow"] is True
    refused = await client.post("/plan", json={**body, "allow_narrow": False})
    assert refused.status_code == 422
    assert "NO_VALID_PATH" in refused.json()["detail"]


async def test_two_calls_suffice(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={"rows": ROWS, "start": [4, 0], "goal": [0, 5]})
    assert r.status_code == 201
    plan = r.json()["plan"]
    path = plan["preview"]["path"]
    for i in range(1, len(path)):
        step = await client.post(f"/plan/{plan['plan_id']}/step", json={"dynamic_obstacles": []})
        assert step.status_code == 200
        assert step.json()["position"] == path[i]
    assert step.json()["status"] == "arrived"
    again = await client.post(f"/plan/{plan['plan_id']}/step", json={"dynamic_obstacles": []})
    assert (again.json()["status"], again.json()["move"]) == ("arrived", "WAIT")


async def test_step_seq_rules(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={"rows": ROWS, "start": [0, 0], "goal": [4, 5]})
    url = f"/plan/{r.json()['plan']['plan_id']}/step"
    first = await client.post(url, json={"seq": 7, "dynamic_obstacles": []})
    assert first.status_code == 200
    assert first.json()["seq"] == 7
    retry = await client.post(url, json={"seq": 7, "dynamic_obstacles": [[1, 1]]})
    assert retry.json() == first.json()
    gap = await client.post(url, json={"seq": 9, "dynamic_obstacles": []})
    assert gap.status_code == 409
    assert "seq 9" in gap.json()["detail"]
    behind = await client.post(url, json={"seq": 6, "dynamic_obstacles": []})
    assert behind.status_code == 409
    nxt = await client.post(url, json={"seq": 8, "dynamic_obstacles": []})
    assert nxt.status_code == 200
    assert nxt.json()["previous"] == first.json()["position"]
    assert nxt.json()["iteration"] == 2


async def test_step_reports_position_and_moves_away(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={"rows": ROWS, "start": [0, 0], "goal": [4, 5]})
    plan_id = r.json()["plan"]["plan_id"]
    step = await client.post(
        f"/plan/{plan_id}/step", json={"position": [2, 2], "dynamic_obstacles": [[2, 2]]}
    )
    assert step.status_code == 200
    assert step.json()["previous"] == [2, 2]
    assert step.json()["move"] != "WAIT"  # an obstacle on the robot's cell: it evades
    assert step.json()["position"] != [2, 2]
    detail = (await client.get(f"/plan/{plan_id}")).json()
    assert detail["trajectory"][:2] == [[0, 0], [2, 2]]
    assert detail["position"] == step.json()["position"]


async def test_get_plan_shows_progress(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={"rows": ROWS, "start": [0, 0], "goal": [4, 5]})
    created = r.json()["plan"]
    for _ in range(3):
        await client.post(f"/plan/{created['plan_id']}/step", json={"dynamic_obstacles": []})
    detail = (await client.get(f"/plan/{created['plan_id']}")).json()
    schemas.PlanDetail.model_validate(detail)
    assert detail["preview"] == created["preview"]
    assert detail["iteration"] == 3
    assert detail["trajectory"] == created["preview"]["path"][:4]
    assert detail["position"] == detail["trajectory"][-1]
    assert detail["metrics"]["moves"] == 3
    assert detail["status"] == "moving"


async def test_delete_plan(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={"rows": ROWS, "start": [0, 0], "goal": [4, 5]})
    plan_id = r.json()["plan"]["plan_id"]
    assert (await client.delete(f"/plan/{plan_id}")).status_code == 204
    assert (await client.get(f"/plan/{plan_id}")).status_code == 404
    assert (await client.delete(f"/plan/{plan_id}")).status_code == 404
    step = await client.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": []})
    assert step.status_code == 404


async def test_plans_expire(app: FastAPI, client: httpx.AsyncClient) -> None:
    now = [0.0]
    app.state.engine.store = MemoryStore(ttl_seconds=60, clock=lambda: now[0])
    r = await client.post("/maps", json={"rows": ROWS, "start": [0, 0], "goal": [4, 5]})
    plan_id = r.json()["plan"]["plan_id"]
    now[0] = 59.0
    assert (await client.post(f"/plan/{plan_id}/step", json={})).status_code == 200
    now[0] = 118.0  # the step restarted the TTL
    assert (await client.get(f"/plan/{plan_id}")).status_code == 200
    now[0] = 119.5
    assert (await client.get(f"/plan/{plan_id}")).status_code == 404


async def test_concurrent_steps_never_lose_or_double_a_move(client: httpx.AsyncClient) -> None:
    grid = [[0] * 30 for _ in range(30)]
    r = await client.post("/maps", json={"grid": grid, "start": [0, 0], "goal": [29, 29]})
    plan_id = r.json()["plan"]["plan_id"]
    url = f"/plan/{plan_id}/step"
    answers = await asyncio.gather(*(client.post(url, json={}) for _ in range(20)))
    steps = [a.json() for a in answers]
    assert sorted(s["seq"] for s in steps) == list(range(20))
    assert sorted(s["iteration"] for s in steps) == list(range(1, 21))
    by_seq = sorted(steps, key=lambda s: s["seq"])
    for before, after in itertools.pairwise(by_seq):
        assert after["previous"] == before["position"]
    detail = (await client.get(f"/plan/{plan_id}")).json()
    assert len(detail["trajectory"]) == 21
    assert detail["trajectory"] == [by_seq[0]["previous"], *(s["position"] for s in by_seq)]


async def test_simulate_is_the_planners_episode(client: httpx.AsyncClient) -> None:
    map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
    body = {"start": [0, 0], "goal": [4, 5], "preset": "mmas", "dynamic_count": 3, "seed": 5}
    r = await client.post(f"/maps/{map_id}/simulate", json=body)
    assert r.status_code == 200
    got = r.json()
    want = planner.simulate(GRID, [0, 0], [4, 5], preset="mmas", dynamic_count=3, seed=5)
    assert got["trajectory"] == want.trajectory.tolist()
    timing = {"analysis_ms", "step_us", "episode_ms"}
    in_meters = {"length_m", "min_clearance_m", "mean_clearance_m"}
    assert {k: v for k, v in got["metrics"].items() if k not in timing | in_meters} == {
        k: v for k, v in want.metrics.items() if k not in timing
    }
    # 1 m a cell: the meters are the cells' figures (the length with diagonals of sqrt 2).
    m = got["metrics"]
    assert m["min_clearance_m"] == pytest.approx(want.metrics["min_clearance"], abs=1e-4)
    assert m["mean_clearance_m"] == pytest.approx(want.metrics["mean_clearance"], abs=1e-4)
    steps = np.abs(np.diff(want.trajectory, axis=0)).sum(axis=1)
    straight, diagonal = int((steps == 1).sum()), int((steps == 2).sum())
    assert m["length_m"] == pytest.approx(straight + diagonal * 2**0.5, abs=1e-5)
    assert got["metrics"]["collisions"] == 0
    again = await client.post(f"/maps/{map_id}/simulate", json=body)
    assert again.json()["trajectory"] == got["trajectory"]


async def test_healthz_and_readyz(client: httpx.AsyncClient) -> None:
    r = await client.get("/healthz")
    assert r.status_code == 200
    assert set(r.json()) == {"status", "uptime_seconds"}
    assert r.json()["status"] == "ok"
    r = await client.get("/readyz")
    assert r.status_code == 200
    assert r.json()["status"] == "ok"
    assert r.json()["store"] == {"kind": "memory", "up": True, "detail": None}
    assert r.json()["pool"] == {"size": 2, "busy": 0, "queued": 0, "warm": True}
    assert r.json()["cache"]["max_bytes"] > 0


async def test_docs_show_a_summary_and_examples_everywhere(client: httpx.AsyncClient) -> None:
    assert (await client.get("/docs")).status_code == 200
    spec = (await client.get("/openapi.json")).json()
    components = spec["components"]["schemas"]
    for path, operations in spec["paths"].items():
        for method, op in operations.items():
            assert op.get("summary"), f"{method} {path} has no summary"
            assert op.get("description"), f"{method} {path} has no description"
            refs = [op.get("requestBody", {}).get("content", {}).get("application/json", {})]
            refs += [
                r.get("content", {}).get("application/json", {}) for r in op["responses"].values()
            ]
            for content in refs:
                ref = content.get("schema", {}).get("$ref")
                if ref:
                    name = ref.rsplit("/", 1)[-1]
                    assert components[name].get("examples"), f"{name} has no example"


def test_presets_match_the_planner() -> None:
    """``schemas`` keeps its own copy of the preset names (it never imports the planner)."""
    assert tuple(planner.PRESETS) == schemas.PRESET_NAMES


async def test_the_documented_examples_chain(client: httpx.AsyncClient) -> None:
    """The examples of /docs, posted in order: map, plan on it, step that plan, simulate."""
    components = (await client.get("/openapi.json")).json()["components"]["schemas"]

    def example(name: str) -> dict[str, object]:
        return dict(components[name]["examples"][0])

    shown_map = example("MapPublic")
    r = await client.post("/maps", json=example("MapCreate"))
    assert r.status_code == 201, r.text
    assert r.json()["map_id"] == shown_map["map_id"] == schemas.EXAMPLE_MAP_ID
    assert {k: r.json()[k] for k in ("height", "width", "free_cells")} == {
        k: shown_map[k] for k in ("height", "width", "free_cells")
    }
    r = await client.post("/plan", json=example("PlanCreate"))
    assert r.status_code == 201, r.text
    plan = r.json()
    shown_plan = example("PlanPublic")
    # /openapi.json leaves null values out of examples (dynamic_margin_m, goal_used: null)
    assert {k: v for k, v in plan["preview"].items() if v is not None} == shown_plan["preview"]
    assert {k: v for k, v in plan["params"].items() if v is not None} == shown_plan["params"]
    assert plan["analysis"]["narrow_fallback"] is False
    r = await client.post(f"/plan/{plan['plan_id']}/step", json=example("StepCreate"))
    assert r.status_code == 200, r.text
    answer, shown = r.json(), example("StepPublic")
    for key in ("path_length", "arc_cost", "remaining"):
        assert answer.pop(key) == pytest.approx(shown.pop(key))
    assert {k: v for k, v in answer.items() if v is not None} == shown  # (waiting_for: null)
    r = await client.post(f"/maps/{plan['map_id']}/simulate", json=example("SimulationCreate"))
    assert r.status_code == 200, r.text


async def test_step_answers_validate_as_their_documented_model(client: httpx.AsyncClient) -> None:
    """The step's answer is built without the response model: it is still
    exactly what StepPublic writes, and its schema is still documented."""
    r = await client.post("/maps", json={"rows": ROWS, "start": [4, 0], "goal": [0, 5]})
    url = f"/plan/{r.json()['plan']['plan_id']}/step"
    for seq in range(12):
        step = await client.post(url, json={"seq": seq, "dynamic_obstacles": [[2, 2]]})
        assert step.status_code == 200
        assert step.headers["content-type"] == "application/json"
        answer = step.json()
        assert schemas.StepPublic.model_validate(answer).model_dump(mode="json") == answer
    spec = (await client.get("/openapi.json")).json()
    ok = spec["paths"]["/plan/{plan_id}/step"]["post"]["responses"]["200"]
    assert ok["content"]["application/json"]["schema"] == {
        "$ref": "#/components/schemas/StepPublic"
    }


def test_step_centers_are_the_frames() -> None:
    from service.api.present import center

    rng = np.random.default_rng(0)
    for yaw in (0.0, 0.3, -2.1, np.pi / 2):
        frame = planner.MapFrame((97, 131), 0.05, (-3.25, 7.125, float(yaw)))
        for r, c in rng.integers(0, 97, size=(50, 2)).tolist():
            assert center(frame, r, c) == frame.centers([[r, c]]).round(6)[0].tolist()


async def test_every_documented_request_example_is_accepted(client: httpx.AsyncClient) -> None:
    """Every request example of /openapi.json, posted: each is answered 2xx."""
    components = (await client.get("/openapi.json")).json()["components"]["schemas"]

    def examples(name: str) -> list[dict[str, object]]:
        shown = components[name]["examples"]
        assert shown, f"{name} has no example"
        return [dict(e) for e in shown]

    for body in examples("MapCreate"):
        r = await client.post("/maps", json=body)
        assert r.status_code in (200, 201), (body, r.text)
    for body in examples("PlanCreate"):
        r = await client.post("/plan", json=body)
        assert r.status_code == 201, (body, r.text)
    plan = r.json()
    for body in examples("StepCreate"):
        r = await client.post(f"/plan/{plan['plan_id']}/step", json=body)
        assert r.status_code == 200, (body, r.text)
    for body in examples("SimulationCreate"):
        r = await client.post(f"/maps/{plan['map_id']}/simulate", json=body)
        assert r.status_code == 200, (body, r.text)


async def test_a_retried_seq_is_no_new_event_for_the_viewer(
    app: FastAPI, client: httpx.AsyncClient
) -> None:
    r = await client.post("/maps", json={"rows": ROWS, "start": [4, 0], "goal": [0, 5]})
    plan_id = r.json()["plan"]["plan_id"]
    subscription = await app.state.bus.subscribe(plan_id)
    try:
        for seq in (0, 0, 1):  # the second is a client's retry of the first
            step = await client.post(f"/plan/{plan_id}/step", json={"seq": seq})
            assert step.status_code == 200
        first, second = await subscription.next(), await subscription.next()
        assert first is not None
        assert second is not None
        assert (orjson.loads(first)["seq"], orjson.loads(second)["seq"]) == (0, 1)
    finally:
        await subscription.close()

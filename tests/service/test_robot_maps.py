"""Robot maps over HTTP (API.md "Robot maps in meters"): ROS YAML + image as multipart,
OccupancyGrid and framed grids, one map_id; points, circles, a robot's radius, meters; against
the shared ROS maps, over ASGI and through a real uvicorn (and the Python client)."""

from __future__ import annotations

import io
import json
import math
import shutil
import subprocess
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from fastapi import FastAPI
from PIL import Image

import planner
from service.client import PlannerClient
from service.config import Settings
from service.work.pictures import MAX_IMAGE_SIDE
from tests import naive
from tests.conftest import ROS_MAP_NAMES
from tests.service.conftest import running

RADIUS = 0.22


def ros_files(ros: Path, name: str) -> tuple[bytes, bytes]:
    """The YAML's bytes and those of the image it names."""
    text = (ros / f"{name}.yaml").read_bytes()
    meta = planner.parse_map_yaml(text)
    return text, (ros / meta.image).read_bytes()


def multipart(yaml: bytes, image: bytes, **fields: str) -> dict[str, Any]:
    return {
        "files": {
            "yaml": ("map.yaml", yaml, "application/yaml"),
            "image": ("map.img", image, "application/octet-stream"),
        },
        "data": fields or None,
    }


def frame_centers(m: planner.RobotMap, cells: Any) -> np.ndarray:
    """API.md's frame formula, written out on its own."""
    H = m.shape[0]
    ox, oy, yaw = m.origin
    out = []
    for r, c in cells:
        u, v = (c + 0.5) * m.resolution, (H - 1 - r + 0.5) * m.resolution
        out.append(
            (ox + math.cos(yaw) * u - math.sin(yaw) * v, oy + math.sin(yaw) * u + math.cos(yaw) * v)
        )
    return np.array(out)


def traversable_pairs(m: planner.RobotMap, count: int, seed: int) -> list[tuple[Any, Any]]:
    """Seeded start/goal points (cell centers) on C-space-traversable cells for RADIUS."""
    cs = planner.configuration_space(m, robot_radius=RADIUS)
    cells = np.argwhere(cs.traversable == 1)
    rng = np.random.default_rng(seed)
    pairs = []
    for _ in range(count):
        a, b = cells[rng.integers(len(cells), size=2)]
        (ax, ay), (bx, by) = m.frame.centers([a, b]).tolist()
        pairs.append(({"x": ax, "y": ay}, {"x": bx, "y": by}))
    return pairs


# --------------------------------------------------------------------------------------------
# Through a real uvicorn


@pytest.mark.parametrize("name", ROS_MAP_NAMES)
def test_ros_maps_upload_as_yaml_and_image_and_as_occupancy_grid_with_one_id(
    live_url: str, ros: Path, name: str
) -> None:
    yaml, image = ros_files(ros, name)
    expected = planner.read_ros_map(ros / f"{name}.yaml")
    meta = planner.parse_map_yaml(yaml)
    with Image.open(io.BytesIO(image)) as picture:
        occupancy = naive.ros_occupancy(
            picture,
            mode=meta.mode,
            negate=meta.negate,
            occupied_thresh=meta.occupied_thresh,
            free_thresh=meta.free_thresh,
        )
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as http:
        r = http.post("/maps", **multipart(yaml, image))
        assert r.status_code in (200, 201), r.text
        got = r.json()
        assert got["map_id"] == expected.map_id
        assert (got["height"], got["width"]) == occupancy.shape
        assert got["free_cells"] == int(np.count_nonzero((occupancy >= 0) & (occupancy < 65)))
        assert got["occupied_cells"] == int(np.count_nonzero(occupancy >= 65))
        assert got["unknown_cells"] == int(np.count_nonzero(occupancy == -1))
        assert got["resolution"] == meta.resolution
        assert got["origin"] == list(meta.origin)
        message = expected.to_occupancy_grid()
        again = http.post("/maps", json={"occupancy_grid": message})
        assert again.status_code == 200, again.text
        assert again.json() == got
        assert http.get(f"/maps/{got['map_id']}").json() == got


def test_a_plan_with_a_radius_on_depot_keeps_its_clearance(live_url: str, ros: Path) -> None:
    m = planner.read_ros_map(ros / "depot.yaml")
    yaml, image = ros_files(ros, "depot")
    distance = planner.configuration_space(m, robot_radius=RADIUS).distance_m
    with httpx.Client(base_url=live_url, trust_env=False, timeout=120) as http:
        map_id = http.post("/maps", **multipart(yaml, image)).json()["map_id"]
        for start, goal in traversable_pairs(m, 20, seed=11):
            body = {"map_id": map_id, "start": start, "goal": goal, "robot_radius": RADIUS}
            r = http.post("/plan", json=body)
            if r.status_code == 422:  # the two points lie in rooms with no way between
                assert "NO_VALID_PATH" in r.json()["detail"], r.text
                continue
            assert r.status_code == 201, r.text
            plan = r.json()
            assert plan["params"]["robot_radius"] == RADIUS
            path = np.array(plan["preview"]["path"])
            assert path[0].tolist() == list(m.frame.cell_of(start))
            assert path[-1].tolist() == list(m.frame.cell_of(goal))
            assert (distance[path[:, 0], path[:, 1]] > RADIUS).all()
            assert (np.abs(np.diff(path, axis=0)).max(axis=1) == 1).all()  # legal moves
            np.testing.assert_allclose(
                plan["preview"]["path_xy"], frame_centers(m, path), atol=1e-6
            )
            preview = plan["preview"]
            assert preview["min_clearance_m"] > RADIUS
            assert preview["min_clearance_m"] == pytest.approx(
                distance[path[:, 0], path[:, 1]].min(), abs=1e-5
            )
            same = planner.plan(m, start, goal, robot_radius=RADIUS)
            assert path.tolist() == same.path.tolist()
            assert preview["length_m"] == pytest.approx(same.length_m, abs=1e-5)


def test_the_client_uploads_a_ros_map_and_plans_in_meters(live_url: str, ros: Path) -> None:
    m = planner.read_ros_map(ros / "depot.yaml")
    (start, goal), *_ = traversable_pairs(m, 1, seed=3)
    with PlannerClient(live_url) as client:
        info = client.upload_map(
            yaml=ros / "depot.yaml", start=start, goal=goal, params={"robot_radius": RADIUS}
        )
        assert info.map_id == m.map_id
        assert info.resolution == 0.05
        assert info.plan is not None
        assert info.plan.params["robot_radius"] == RADIUS
        assert info.plan.preview.min_clearance_m is not None
        assert info.plan.preview.min_clearance_m > RADIUS
        assert info.plan.preview.path_xy is not None
        assert info.plan.preview.path_xy[0] == pytest.approx([start["x"], start["y"]])
        far = {"x": start["x"] + 5.0, "y": start["y"], "radius": 0.1}
        step = client.step(info.plan.plan_id, [far], seq=0)
        assert step.position_xy is not None
        assert step.position_xy == pytest.approx(frame_centers(m, [step.position])[0].tolist())
        png = client.render_plan(info.plan.plan_id)
    with Image.open(io.BytesIO(png)) as picture:
        assert max(picture.size) <= MAX_IMAGE_SIDE


def test_testmap_points_use_its_yaw(live_url: str, ros: Path) -> None:
    m = planner.read_ros_map(ros / "testmap.yaml")
    yaml, image = ros_files(ros, "testmap")
    free = np.argwhere(planner.configuration_space(m).traversable == 1)
    a, b = free[0], free[-1]
    (ax, ay), (bx, by) = frame_centers(m, [a, b]).tolist()
    fields = {"start": f'{{"x": {ax}, "y": {ay}}}', "goal": f'{{"x": {bx}, "y": {by}}}'}
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as http:
        r = http.post("/maps", **multipart(yaml, image, **fields, preset="shortest"))
        assert r.status_code in (200, 201), r.text
        plan = r.json()["plan"]
        assert plan["start"] == a.tolist()
        assert plan["goal"] == b.tolist()
        assert plan["position_xy"] == pytest.approx([ax, ay], abs=1e-6)
        path = plan["preview"]["path"]
        np.testing.assert_allclose(plan["preview"]["path_xy"], frame_centers(m, path), atol=1e-6)


def test_a_circle_blocks_the_cells_in_reach_in_a_step_on_depot(live_url: str, ros: Path) -> None:
    m = planner.read_ros_map(ros / "depot.yaml")
    yaml, image = ros_files(ros, "depot")
    (start, goal), *_ = traversable_pairs(m, 1, seed=4)
    with httpx.Client(base_url=live_url, trust_env=False, timeout=60) as http:
        map_id = http.post("/maps", **multipart(yaml, image)).json()["map_id"]
        body = {"map_id": map_id, "start": start, "goal": goal, "robot_radius": RADIUS,
                "params": {"dynamic_margin": 0}}  # fmt: skip
        plan = http.post("/plan", json=body).json()
        path = plan["preview"]["path"]
        nxt = frame_centers(m, [path[1]])[0]
        # Centered 0.05 m beyond the next cell's center: radius + robot radius reaches it.
        circle = {"x": nxt[0] + 0.05, "y": nxt[1], "radius": 0.1}
        step = http.post(f"/plan/{plan['plan_id']}/step", json={"dynamic_obstacles": [circle]})
        assert step.status_code == 200, step.text
        assert step.json()["position"] != path[1]
        assert step.json()["position_xy"] == pytest.approx(
            frame_centers(m, [step.json()["position"]])[0].tolist(), abs=1e-6
        )
        # The same circle 0.4 m further does not stop the robot: it moves on, round the circle
        # at once if it stands on the way ahead, its poses clear of it.
        plan = http.post("/plan", json=body).json()
        away = {**circle, "x": circle["x"] + 0.4}
        step = http.post(f"/plan/{plan['plan_id']}/step", json={"dynamic_obstacles": [away]})
        assert step.json()["status"] in ("moving", "replanned"), step.text
        assert step.json()["position"] != start
        reach = away["radius"] + RADIUS
        xy = np.array([[p["x"], p["y"]] for p in step.json()["poses"]])
        assert (np.hypot(*(xy - [away["x"], away["y"]]).T) > reach).all()


# --------------------------------------------------------------------------------------------
# Over ASGI


@pytest.fixture
def settings() -> Settings:
    return Settings(pool_size=2, max_map_cells=4096, max_body_bytes=1 << 20)


@pytest.fixture
async def small(app: FastAPI) -> AsyncIterator[httpx.AsyncClient]:
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            yield c


# A 0.1 m room, 5 x 9 cells, a wall with a one-cell door at column 4 (row 2).
ROOM = [
    [0, 0, 0, 0, 0, 0, 0, 0, 0],
    [0, 0, 0, 0, 0, 0, 0, 0, 0],
    [1, 1, 1, 1, 0, 1, 1, 1, 1],
    [0, 0, 0, 0, 0, 0, 0, 0, 0],
    [0, 0, 0, 0, 0, 0, 0, 0, -1],
]
FRAME = {"resolution": 0.1, "origin": [-1.0, 2.0, 0.0]}


@pytest.mark.anyio
async def test_one_map_one_id_as_grid_and_as_occupancy_grid(small: httpx.AsyncClient) -> None:
    expected = planner.grid_map(ROOM, resolution=0.1, origin=(-1.0, 2.0, 0.0))
    r = await small.post("/maps", json={"grid": ROOM, **FRAME})
    assert r.status_code == 201, r.text
    got = r.json()
    assert got["map_id"] == expected.map_id
    assert (got["unknown_cells"], got["occupied_cells"], got["free_cells"]) == (1, 8, 36)
    assert (got["resolution"], got["origin"]) == (0.1, [-1.0, 2.0, 0.0])
    again = await small.post("/maps", json={"occupancy_grid": expected.to_occupancy_grid()})
    assert (again.status_code, again.json()["map_id"]) == (200, expected.map_id)
    # The same cells in the default frame are another map.
    other = await small.post("/maps", json={"grid": ROOM})
    assert other.json()["map_id"] != expected.map_id


@pytest.mark.anyio
async def test_points_in_and_out_and_the_radius_is_echoed_and_keys_the_cache(
    small: httpx.AsyncClient,
) -> None:
    map_id = (await small.post("/maps", json={"grid": ROOM, **FRAME})).json()["map_id"]
    # Cell [0, 0]'s center: x = -1 + 0.05, y = 2 + (5 - 1 - 0 + 0.5) 0.1.
    start, goal = {"x": -0.95, "y": 2.45}, {"x": -0.15, "y": 2.05}
    body = {"map_id": map_id, "start": start, "goal": goal, "unknown": "free"}
    first = (await small.post("/plan", json=body)).json()
    assert (first["start"], first["goal"]) == ([0, 0], [4, 8])  # [4, 8] is unknown: free here
    assert first["params"]["unknown"] == "free"
    assert first["position_xy"] == pytest.approx([-0.95, 2.45])
    assert first["analysis"]["cache_hit"] is False
    again = (await small.post("/plan", json=body)).json()
    assert again["analysis"]["cache_hit"] is True
    wider = (await small.post("/plan", json={**body, "robot_radius": 0.04})).json()
    assert wider["params"]["robot_radius"] == 0.04
    assert wider["analysis"]["cache_hit"] is False
    step = await small.post(
        f"/plan/{first['plan_id']}/step", json={"position": {"x": -0.85, "y": 2.45}}
    )
    assert step.status_code == 200, step.text
    assert step.json()["previous"] == [0, 1]
    detail = (await small.get(f"/plan/{first['plan_id']}")).json()
    assert detail["trajectory_xy"][0] == pytest.approx([-0.95, 2.45])
    moves = np.diff(np.array(detail["trajectory"]), axis=0)
    assert len(moves) == 2  # reported at [0, 1], then one move
    assert detail["metrics"]["length_m"] == pytest.approx(0.1 * np.hypot(*moves.T).sum())
    sim = await small.post(
        f"/maps/{map_id}/simulate",
        json={
            "start": start,
            "goal": goal,
            "robot_radius": 0.04,
            "unknown": "free",
            "dynamic_count": 0,
        },
    )
    assert sim.status_code == 200, sim.text
    assert sim.json()["metrics"]["min_clearance_m"] == pytest.approx(
        sim.json()["metrics"]["min_clearance"] * 0.1, abs=1e-4
    )


@pytest.mark.anyio
async def test_a_start_the_robot_cannot_stand_on_is_named(small: httpx.AsyncClient) -> None:
    map_id = (await small.post("/maps", json={"grid": ROOM, **FRAME})).json()["map_id"]
    # Cell [1, 2] is free, 0.1 m from the wall: a robot of 0.12 m does not fit there; [0, 0]
    # is 0.2 m from it (the outside counting as free).
    point = {"x": -0.75, "y": 2.35}
    body = {"map_id": map_id, "start": point, "goal": [0, 0], "robot_radius": 0.12,
            "unknown": "free"}  # fmt: skip
    r = await small.post("/plan", json=body)
    assert r.status_code == 422
    error = r.json()
    assert (error["code"], error["field"]) == ("START_OCCUPIED", "start")
    for text in ("'x': -0.75", "[1, 2]", "clearance 0.100 m", "robot_radius 0.12"):
        assert text in error["detail"]
    r = await small.post("/plan", json={**body, "start": [0, 0], "goal": point})
    assert (r.status_code, r.json()["code"], r.json()["field"]) == (422, "GOAL_OCCUPIED", "goal")
    made = await small.post("/plan", json={**body, "start": [0, 0], "goal": [0, 1]})
    r = await small.post(f"/plan/{made.json()['plan_id']}/step", json={"position": point})
    assert (r.status_code, r.json()["code"], r.json()["field"]) == (
        422,
        "POSITION_OCCUPIED",
        "position",
    )
    assert (await small.post("/plan", json={**body, "robot_radius": 0.09})).status_code == 201


@pytest.mark.anyio
async def test_a_circle_blocks_exactly_the_cells_within_its_radius_plus_the_robots(
    small: httpx.AsyncClient,
) -> None:
    corridor = [[0] * 9 for _ in range(3)]
    body = {"grid": corridor, "resolution": 0.1, "start": [1, 0], "goal": [1, 8],
            "preset": "shortest", "params": {"dynamic_margin": 0, "patience": 0}}  # fmt: skip
    # Cell [1, 1]'s center is (0.15, 0.15); a circle at (0.15, 0.35) is 0.2 m from it, 0.1 m
    # from [0, 1], 0.141 m from [0, 0] and [0, 2], 0.224 m from [1, 0] (the robot) and [1, 2].
    center = {"x": 0.15, "y": 0.35}

    async def first_move(circle_radius: float, **extra: Any) -> list[int]:
        plan = (await small.post("/maps", json={**body, **extra})).json()["plan"]
        circle = {**center, "radius": circle_radius}
        r = await small.post(f"/plan/{plan['plan_id']}/step", json={"dynamic_obstacles": [circle]})
        assert r.status_code == 200, r.text
        position: list[int] = r.json()["position"]
        return position

    assert await first_move(0.19) == [1, 1]  # row 0 blocked, the way ahead free
    assert (await first_move(0.21))[0] == 2  # [1, 1] blocked too: round it, below
    # The robot's radius counts: 0.19 + 0.02 reaches [1, 1]'s center.
    assert (await first_move(0.19, robot_radius=0.02, unknown="free"))[0] == 2


@pytest.mark.anyio
async def test_render_a_robot_map_with_its_margin_stays_bounded(small: httpx.AsyncClient) -> None:
    map_id = (await small.post("/maps", json={"grid": ROOM, **FRAME})).json()["map_id"]
    plain = await small.get(f"/maps/{map_id}/render.png")
    margin = await small.get(f"/maps/{map_id}/render.png", params={"robot_radius": 0.12})
    assert plain.status_code == margin.status_code == 200
    assert plain.content != margin.content  # the pink margin
    with Image.open(io.BytesIO(margin.content)) as picture:
        assert max(picture.size) <= MAX_IMAGE_SIDE
    bad = await small.get(f"/maps/{map_id}/render.png", params={"robot_radius": -1})
    assert bad.status_code == 422


# --------------------------------------------------------------------------------------------
# Bad multipart uploads (JSON ones are in test_bad_input.py's table)

YAML = b"image: m.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"
PGM = b"P5 3 2 255\n" + bytes([255, 255, 0, 205, 255, 255])  # [0, 2] occupied, [1, 0] unknown


@pytest.mark.parametrize(
    ("yaml", "image", "status", "texts"),
    [
        (b"- 1\n- 2\n", PGM, 422, ["yaml", "mapping", "[1, 2]"]),
        (b"image: m.pgm\norigin: [0, 0, 0]\n", PGM, 422, ["yaml", "'resolution'"]),
        (b"image: m.pgm\nresolution: 0.05\n", PGM, 422, ["yaml", "'origin'"]),
        (YAML.replace(b"0.05", b"-0.05"), PGM, 422, ["yaml.resolution", "-0.05"]),
        (YAML.replace(b"0.05", b".nan"), PGM, 422, ["yaml.resolution", "nan"]),
        (YAML + b"mode: colour\n", PGM, 422, ["yaml.mode", "'colour'"]),
        (YAML + b"occupied_thresh: 1.5\n", PGM, 422, ["yaml.occupied_thresh", "1.5"]),
        (YAML + b"free_thresh: 0.7\n", PGM, 422, ["yaml.free_thresh", "0.7", "0.65"]),
        (YAML, b"GIF89a-not-really", 422, ["image", "GIF89a"]),
        (YAML, b"P5 3 2 255\n", 422, ["image", "decode"]),
        (YAML, b"P5 100 100 255\n", 413, ["image", "100 x 100", "10000", "4096"]),
    ],
)
@pytest.mark.anyio
async def test_bad_ros_maps_are_named(
    small: httpx.AsyncClient, yaml: bytes, image: bytes, status: int, texts: list[str]
) -> None:
    r = await small.post("/maps", **multipart(yaml, image))
    assert r.status_code == status, r.text
    for text in texts:
        assert text in r.json()["detail"], r.json()


@pytest.mark.anyio
async def test_multipart_needs_both_parts_and_known_fields(small: httpx.AsyncClient) -> None:
    only_yaml = await small.post("/maps", files={"yaml": ("m.yaml", YAML, "application/yaml")})
    assert only_yaml.status_code == 422
    assert "'image' part" in only_yaml.json()["detail"]
    unknown = await small.post("/maps", **multipart(YAML, PGM, speed="3"))
    assert unknown.status_code == 422
    assert "speed" in unknown.json()["detail"]
    good = await small.post("/maps", **multipart(YAML, PGM, start="[0, 0]", goal="[1, 2]",
                                                 preset="shortest", robot_radius="0"))  # fmt: skip
    assert good.status_code == 201, good.text
    assert good.json()["unknown_cells"] == 1
    assert good.json()["plan"]["goal"] == [1, 2]
    as_json = await small.post("/maps", json={"yaml": "image: m.pgm", "image": "x"})
    assert as_json.status_code == 422
    assert "multipart" in as_json.json()["detail"]


def test_the_readme_walkthrough_runs_as_written(live_url: str, ros: Path, tmp_path: Path) -> None:
    if shutil.which("curl") is None:
        pytest.skip("curl is not installed")
    page = (Path(__file__).resolve().parents[2] / "docs" / "robot-maps.md").read_text("utf-8")
    section = page.split("## A real robot map, step by step", 1)[1]
    script = section.split("```sh\n", 1)[1].split("```", 1)[0]
    assert 'R=$PWD/examples/maps\ncd "$(mktemp -d)"' in script
    root = Path(__file__).resolve().parents[2]
    script = script.replace("R=$PWD/examples/maps", f"R={root / 'examples' / 'maps'}")
    script = script.replace('cd "$(mktemp -d)"', f"cd {tmp_path}")
    script = script.replace("localhost:8000", live_url.removeprefix("http://"))
    run = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", script],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    plan = json.loads((tmp_path / "plan.json").read_text())
    assert plan["params"]["robot_radius"] == RADIUS
    assert plan["start"] == [26, 136]
    assert plan["preview"]["length_m"] == pytest.approx(18.531371)
    assert '"move":"WAIT"' in run.stdout
    assert '"position":[26,137]' in run.stdout
    for name in ("plan.png", "map.png"):
        assert (tmp_path / name).read_bytes().startswith(b"\x89PNG"), name

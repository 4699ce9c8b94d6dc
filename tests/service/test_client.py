"""``service.client`` against a live uvicorn server (and, for the ROS YAML upload, whose server
side is not here yet, against a mock transport that reads the multipart parts)."""

from __future__ import annotations

import email.parser
import email.policy
import inspect
import json
import subprocess
import sys
from email.message import EmailMessage
from pathlib import Path
from typing import Any, get_args, get_type_hints

import httpx
import pytest
from fastapi import FastAPI
from pydantic import BaseModel

import schemas
import schemas.plans
from service.client import (
    APIError,
    AsyncPlannerClient,
    ConflictError,
    MapfFields,
    MapFileError,
    MapInfo,
    NotFoundError,
    NoValidPathError,
    PlanFields,
    PlannerClient,
    RouteFields,
    SimulateFields,
    StepFields,
    UnavailableError,
    UploadMapFields,
    ValidationError,
    ZonesFields,
)
from tests.service.conftest import ROOT, random_map

GRID = random_map(20, 20, 0.15, seed=7).tolist()
ROWS = ["".join(".@"[c] for c in row) for row in GRID]
WALLED = [[0, 0, 0, 0, 0], [0, 0, 1, 1, 1], [0, 0, 1, 0, 0], [0, 0, 1, 0, 0]]


def test_importing_the_client_imports_no_fastapi_and_builds_no_app() -> None:
    code = (
        "import sys, service.client; "
        "loaded = [m for m in sys.modules if m.split('.')[0] in ('fastapi', 'starlette')"
        " or m in ('service.main', 'service.work.engine', 'planner')]; "
        "assert not loaded, loaded"
    )
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True)


def test_a_session_through_the_client(live_url: str) -> None:
    with PlannerClient(live_url) as planner:
        info = planner.upload_map(grid=GRID, start=[0, 0], goal=[19, 19], preset="wide")
        assert isinstance(info, MapInfo)
        assert (info.height, info.width) == (20, 20)
        assert info.free_cells == sum(row.count(0) for row in GRID)
        assert info.plan is not None
        plan = info.plan
        assert plan.map_id == info.map_id
        assert plan.start == [0, 0]
        assert plan.goal == [19, 19]
        assert plan.status == "ready"
        assert plan.preview.path[0] == [0, 0]
        assert plan.preview.path[-1] == [19, 19]
        assert plan.analysis.gates >= 0
        assert plan.params["alpha"] == 3.0
        again = planner.upload_map(rows=ROWS)  # the same map, sent as rows
        assert again.map_id == info.map_id
        assert again.created is False
        assert again.plan is None
        assert planner.get_map(info.map_id).free_cells == info.free_cells

        other = planner.plan(info.map_id, [0, 0], [19, 19], preset="shortest", params={"beta": 2})
        assert other.preset == "shortest"
        assert other.params["beta"] == 2.0
        nav = planner.path(plan.plan_id, frame_id="odom")
        assert nav.header.frame_id == "odom"
        assert [(p.pose.position.x, p.pose.position.y) for p in nav.poses] == [
            (p.x, p.y) for p in plan.preview.poses
        ]
        tolerant = planner.plan(
            info.map_id, [0, 0], {"x": 19.5, "y": 0.5, "yaw": 1.0}, goal_tolerance=0.5
        )
        assert tolerant.preview.poses[-1].yaw == pytest.approx(1.0)
        path = plan.preview.path
        first = planner.step(plan.plan_id, [], seq=0)
        assert (first.seq, first.previous, first.position) == (0, path[0], path[1])
        assert first.move in {"N", "NE", "E", "SE", "S", "SW", "W", "NW"}
        assert planner.step(plan.plan_id, [], seq=0) == first  # a retry: the same answer
        second = planner.step(plan.plan_id, [[5, 5]], seq=1, position=path[1])
        assert second.iteration == 2
        detail = planner.get_plan(plan.plan_id)
        assert detail.iteration == 2
        assert detail.trajectory == [path[0], path[1], second.position]
        assert detail.metrics["moves"] == 2
        assert detail.preview == plan.preview

        episode = planner.simulate(info.map_id, [0, 0], [19, 19], dynamic_count=3, seed=1)
        assert episode.metrics["collisions"] == 0
        assert episode.trajectory[0] == [0, 0]
        replay = planner.simulate(info.map_id, [0, 0], [19, 19], dynamic_count=3, seed=1)
        assert replay.trajectory == episode.trajectory  # seeded

        png = planner.render_map(info.map_id, field="clean", cell=2)
        assert png.startswith(b"\x89PNG")
        assert int.from_bytes(png[16:20], "big") >= 40  # 20 cells of 2 pixels, and the legend
        assert planner.render_plan(plan.plan_id).startswith(b"\x89PNG")

        planner.delete_plan(plan.plan_id)
        with pytest.raises(NotFoundError):
            planner.get_plan(plan.plan_id)


def test_error_answers_raise_typed_errors(live_url: str) -> None:
    with PlannerClient(live_url) as planner:
        with pytest.raises(NotFoundError) as missing:
            planner.get_map("0" * 64)
        assert missing.value.status_code == 404
        assert missing.value.code == "NOT_FOUND"
        assert missing.value.field == "map_id"
        assert "0" * 64 in missing.value.detail

        info = planner.upload_map(grid=GRID)
        with pytest.raises(ValidationError) as outside:
            planner.plan(info.map_id, [0, 0], [40, 0])
        assert outside.value.status_code == 422
        assert outside.value.code == "INVALID_INPUT"
        assert outside.value.field == "goal"
        assert "[40, 0]" in outside.value.detail

        walled = planner.upload_map(grid=WALLED)
        with pytest.raises(NoValidPathError) as unreachable:
            planner.plan(walled.map_id, [0, 0], [3, 4])
        assert isinstance(unreachable.value, ValidationError)
        assert "NO_VALID_PATH" in unreachable.value.detail

        plan = planner.plan(info.map_id, [0, 0], [19, 19])
        planner.step(plan.plan_id, [], seq=0)
        with pytest.raises(ConflictError) as conflict:
            planner.step(plan.plan_id, [], seq=5)
        assert conflict.value.status_code == 409
        assert conflict.value.code == "SEQUENCE_CONFLICT"
        with pytest.raises(ValidationError):
            planner.step(plan.plan_id, [[99, 99]])
        with pytest.raises(APIError) as bad_render:
            planner.render_plan(plan.plan_id, cell=0)
        assert bad_render.value.status_code == 422
    for kind in (NotFoundError, ValidationError, ConflictError, UnavailableError):
        assert issubclass(kind, APIError)
    assert not issubclass(NotFoundError, ValidationError)
    assert not issubclass(ValidationError, NotFoundError)


@pytest.mark.anyio
async def test_the_async_client(live_url: str) -> None:
    async with AsyncPlannerClient(live_url) as planner:
        info = await planner.upload_map(rows=ROWS, start=[0, 0], goal=[19, 19])
        assert info.plan is not None
        plan_id = info.plan.plan_id
        path = info.plan.preview.path
        step = await planner.step(plan_id, [], seq=0)
        assert step.position == path[1]
        assert (await planner.get_plan(plan_id)).iteration == 1
        assert (await planner.get_map(info.map_id)).map_id == info.map_id
        plan = await planner.plan(info.map_id, [0, 0], [19, 19], preset="mmas")
        assert plan.preset == "mmas"
        episode = await planner.simulate(info.map_id, [0, 0], [19, 19], dynamic_count=2, seed=3)
        assert episode.metrics["reached"] in (True, False)
        assert (await planner.render_map(info.map_id)).startswith(b"\x89PNG")
        assert (await planner.render_plan(plan_id)).startswith(b"\x89PNG")
        await planner.delete_plan(plan_id)
        with pytest.raises(NotFoundError):
            await planner.delete_plan(plan_id)
        with pytest.raises(ValidationError):
            await planner.plan(info.map_id, [0, 0], [-1, 0])


def _parts(request: httpx.Request) -> dict[str, EmailMessage]:
    """The parts of a multipart/form-data request by name."""
    head = f"Content-Type: {request.headers['content-type']}\r\n\r\n".encode()
    message = email.parser.BytesParser(policy=email.policy.HTTP).parsebytes(head + request.content)
    assert isinstance(message, EmailMessage)
    parts = {}
    for part in message.iter_parts():
        assert isinstance(part, EmailMessage)
        name = part.get_param("name", header="content-disposition")
        assert isinstance(name, str)
        parts[name] = part
    return parts


def test_a_ros_map_yaml_is_posted_with_its_image(tmp_path: Path) -> None:
    maps = tmp_path / "maps"
    maps.mkdir()
    pgm = b"P5\n3 2\n255\n" + bytes([254, 0, 254, 254, 254, 205])
    (maps / "office.pgm").write_bytes(pgm)
    yaml_text = (
        "# a map_server map\nimage: 'office.pgm'  # beside this file\nresolution: 0.05\n"
        "origin: [-1.0, -2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    (maps / "office.yaml").write_text(yaml_text)
    seen: list[httpx.Request] = []
    answer = {"map_id": "ab" * 32, "height": 2, "width": 3, "free_cells": 4, "occupied_cells": 1,
              "unknown_cells": 1, "resolution": 0.05, "origin": [-1.0, -2.0, 0.0]}  # fmt: skip

    def handler(request: httpx.Request) -> httpx.Response:
        seen.append(request)
        return httpx.Response(201, json=answer)

    transport = httpx.MockTransport(handler)
    with PlannerClient("http://planner", transport=transport) as planner:
        info = planner.upload_map(yaml=maps / "office.yaml", start=[0, 0], goal={"x": 0.1, "y": 0})
    assert (info.map_id, info.height, info.width, info.created) == (answer["map_id"], 2, 3, True)
    (request,) = seen
    assert request.method == "POST"
    assert request.url.path == "/maps"
    assert request.headers["content-type"].startswith("multipart/form-data; boundary=")
    parts = _parts(request)
    assert set(parts) == {"yaml", "image", "start", "goal"}
    assert parts["yaml"].get_filename() == "office.yaml"
    assert parts["yaml"].get_payload(decode=True) == yaml_text.encode()
    assert parts["image"].get_filename() == "office.pgm"
    assert parts["image"].get_payload(decode=True) == pgm
    assert json.loads(parts["start"].get_content()) == [0, 0]
    assert json.loads(parts["goal"].get_content()) == {"x": 0.1, "y": 0}


def test_a_yaml_without_its_image_is_refused_before_sending(tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text("resolution: 0.05\norigin: [0, 0, 0]\n")
    (tmp_path / "n.yaml").write_text("image: n.pgm\nresolution: 0.05\n")

    def handler(request: httpx.Request) -> httpx.Response:
        raise AssertionError("sent")

    with PlannerClient("http://planner", transport=httpx.MockTransport(handler)) as planner:
        with pytest.raises(MapFileError, match="image"):
            planner.upload_map(yaml=tmp_path / "m.yaml")
        # Not a bare FileNotFoundError: the client's error, naming the image the YAML names.
        with pytest.raises(
            MapFileError, match=r"n\.pgm' that n\.yaml names does not exist"
        ) as info:
            planner.upload_map(yaml=tmp_path / "n.yaml")
        assert info.value.path == tmp_path / "n.pgm"
        assert isinstance(info.value, ValueError)
        with pytest.raises(MapFileError, match=r"gone\.yaml"):
            planner.upload_map(yaml=tmp_path / "gone.yaml")
        with pytest.raises(TypeError, match="exactly one"):
            planner.upload_map(grid=[[0]], rows=["."])
        with pytest.raises(TypeError, match="exactly one"):
            planner.upload_map()


def test_a_store_out_of_reach_raises_unavailable_with_its_retry_after() -> None:
    body: dict[str, Any] = {
        "detail": "store unavailable",
        "field": None,
        "code": "STORE_UNAVAILABLE",
    }

    def handler(request: httpx.Request) -> httpx.Response:
        return httpx.Response(503, json=body, headers={"Retry-After": "1"})

    transport = httpx.MockTransport(handler)
    with (
        PlannerClient("http://planner", transport=transport) as planner,
        pytest.raises(UnavailableError) as down,
    ):
        planner.get_plan("p")
    assert down.value.retry_after == 1.0
    assert down.value.code == "STORE_UNAVAILABLE"
    assert down.value.field is None


def test_the_readme_example_runs(live_url: str, tmp_path: Path, monkeypatch: Any) -> None:
    readme = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    section = readme.split("## The Python client", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    assert 'PlannerClient("http://127.0.0.1:8000")' in code
    monkeypatch.chdir(tmp_path)
    exec(compile(code.replace("http://127.0.0.1:8000", live_url), "docs/api.md", "exec"), {})
    assert (tmp_path / "plan.png").read_bytes().startswith(b"\x89PNG")


def test_the_readme_example_type_checks(tmp_path: Path) -> None:
    readme = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    code = readme.split("## The Python client", 1)[1].split("```python\n", 1)[1].split("```")[0]
    (tmp_path / "readme_client.py").write_text(code)
    mypy = [sys.executable, "-m", "mypy", "--strict", str(tmp_path / "readme_client.py")]
    checked = subprocess.run(mypy, cwd=ROOT, capture_output=True, text=True)
    assert checked.returncode == 0, checked.stdout + checked.stderr


OCCUPANCY_GRID = {
    "info": {"resolution": 0.5, "width": 3, "height": 2,
             "origin": {"position": {"x": -1.0, "y": 0.0, "z": 0.0}}},
    "data": [0, 0, 0, 0, 100, -1],
}  # fmt: skip
EVERY_OPTION: dict[str, Any] = {
    "preset": "wfs-mmas",
    "params": {"alpha": 2},
    "max_steps": 50,
    "obstacle_motion": "simultaneous",
    "robot_radius": 0.4,
    "unknown": "free",
    "allow_narrow": False,
}


def test_every_field_of_a_map_and_a_simulation_is_sent(live_url: str) -> None:
    with PlannerClient(live_url) as planner:
        ros = planner.upload_map(
            occupancy_grid=OCCUPANCY_GRID,
            start={"x": -0.75, "y": 0.75},
            goal={"x": 0.25, "y": 0.25},
        )
        assert (ros.height, ros.width, ros.resolution, ros.unknown_cells) == (2, 3, 0.5, 1)
        assert ros.origin == [-1.0, 0.0, 0.0]
        assert ros.plan is not None
        framed = planner.upload_map(
            grid=[[0, 0, -1], [0, 1, 0]], resolution=0.05, origin=(-1, 2, 0)
        )
        assert (framed.resolution, framed.origin) == (0.05, [-1.0, 2.0, 0.0])
        info = planner.upload_map(grid=GRID)
        episode = planner.simulate(
            info.map_id, [0, 0], [19, 19], dynamic_count=3, seed=1, **EVERY_OPTION
        )
        assert episode.obstacle_motion == "simultaneous"
        assert 1 <= episode.metrics["iterations"] <= 50
        # Each is sent: a value the server refuses shows it.
        with pytest.raises(ValidationError, match="START_OCCUPIED"):
            planner.simulate(info.map_id, [0, 0], [19, 19], dynamic_count=1, seed=1, robot_radius=1)
        with pytest.raises(ValidationError) as refused:
            planner.simulate(info.map_id, [0, 0], [19, 19], dynamic_count=1, seed=1, unknown="x")
        assert refused.value.field == "unknown"
        with pytest.raises(ValidationError) as refused:
            planner.simulate(info.map_id, [0, 0], [19, 19], dynamic_count=1, seed=1, max_steps=0)
        assert refused.value.field == "max_steps"
    seen: list[dict[str, Any]] = []

    def handler(request: httpx.Request) -> httpx.Response:
        seen.append(json.loads(request.content))
        return httpx.Response(200, json=_example(schemas.SimulationPublic))

    with PlannerClient("http://planner", transport=httpx.MockTransport(handler)) as planner:
        planner.simulate("m", [0, 0], [1, 1], dynamic_count=2, seed=3, **EVERY_OPTION)
        planner.simulate("m", [0, 0], [1, 1], dynamic_count=2, seed=3)
    assert seen == [
        {"start": [0, 0], "goal": [1, 1], "dynamic_count": 2, "seed": 3, **EVERY_OPTION},
        {"start": [0, 0], "goal": [1, 1], "dynamic_count": 2, "seed": 3},
    ]


@pytest.mark.anyio
async def test_the_async_client_sends_every_field_too(live_url: str) -> None:
    async with AsyncPlannerClient(live_url) as planner:
        ros = await planner.upload_map(occupancy_grid=OCCUPANCY_GRID)
        assert (ros.resolution, ros.origin) == (0.5, [-1.0, 0.0, 0.0])
        framed = await planner.upload_map(rows=["..", ".@"], resolution=0.1, origin=[1, 1, 0])
        assert (framed.resolution, framed.origin) == (0.1, [1.0, 1.0, 0.0])
        info = await planner.upload_map(grid=GRID)
        episode = await planner.simulate(
            info.map_id, [0, 0], [19, 19], dynamic_count=3, seed=1, **EVERY_OPTION
        )
        assert episode.obstacle_motion == "simultaneous"
        with pytest.raises(ValidationError, match="START_OCCUPIED"):
            await planner.simulate(
                info.map_id, [0, 0], [19, 19], dynamic_count=1, seed=1, robot_radius=1
            )


def _example(model: type[BaseModel]) -> Any:
    return model.model_json_schema()["examples"][0]


# Each method of the client and the route it calls.
ROUTES = {
    "upload_map": ("post", "/maps"),
    "get_map": ("get", "/maps/{map_id}"),
    "passages": ("get", "/maps/{map_id}/passages"),
    "add_zones": ("post", "/maps/{map_id}/zones"),
    "plan": ("post", "/plan"),
    "get_plan": ("get", "/plan/{plan_id}"),
    "path": ("get", "/plan/{plan_id}/path"),
    "step": ("post", "/plan/{plan_id}/step"),
    "simulate": ("post", "/maps/{map_id}/simulate"),
    "fleet": ("get", "/fleets/{fleet}"),
    "change_goal": ("patch", "/plan/{plan_id}"),
    "mapf": ("post", "/maps/{map_id}/mapf"),
    "observe": ("post", "/maps/{map_id}/observations"),
    "live": ("get", "/maps/{map_id}/live"),
}


def _models(annotation: Any) -> list[type[BaseModel]]:
    """The models in a field's annotation (``PlanPublic | None``, ``list[...]``)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in get_args(annotation) for m in _models(arg)]


def _missing(schema: type[BaseModel], result: type[BaseModel], where: str) -> list[str]:
    """The fields of ``schema``, nested ones too, that ``result`` lacks."""
    missing = []
    for name, field in schema.model_fields.items():
        if name not in result.model_fields:
            missing.append(f"{where}.{name}")
            continue
        ours = _models(result.model_fields[name].annotation)
        for nested in _models(field.annotation):
            if not ours:
                missing.append(f"{where}.{name}: {nested.__name__}")
            for model in ours:
                missing += _missing(nested, model, f"{where}.{name}")
    return missing


@pytest.mark.parametrize("kind", [PlannerClient, AsyncPlannerClient])
def test_the_results_have_every_field_of_the_response_models(kind: type, app: FastAPI) -> None:
    """Each method's result type has every field of its route's response model (the one
    /openapi.json documents), nested models too: adding a field to a schema cannot leave the
    client behind."""
    spec = app.openapi()
    for name, (method, path) in ROUTES.items():
        answers = spec["paths"][path][method]["responses"]
        refs = {
            answer["content"]["application/json"]["schema"]["$ref"]
            for status, answer in answers.items()
            if status.startswith("2")
        }
        assert refs, f"{method} {path} documents no answer"
        result = get_type_hints(getattr(kind, name))["return"]
        for ref in refs:
            schema = getattr(schemas, ref.rsplit("/", 1)[-1])
            assert issubclass(result, schema), (name, result, schema)
            assert _missing(schema, result, name) == []


def test_the_field_check_sees_a_missing_field() -> None:
    class Short(BaseModel):
        gates: int

    class Holder(BaseModel):
        analysis: Short | None

    assert _missing(schemas.AnalysisPublic, Short, "a") == [
        "a.tunnels", "a.narrow_fallback", "a.cache_hit", "a.analysis_ms"
    ]  # fmt: skip
    assert "p.analysis.tunnels" in _missing(schemas.PlanPublic, Holder, "p")


def test_the_client_sends_every_field_of_the_request_models() -> None:
    """What each method can send is what its request model takes, no less and no more."""
    plan_fields = set(get_type_hints(PlanFields))
    assert plan_fields == set(schemas.plans.PlanOptions.model_fields)
    upload = set(get_type_hints(UploadMapFields))
    assert upload == set(schemas.MapCreate.model_fields) - {"image"}  # the YAML's image is read
    # An upload with a start and a goal is a plan's request too (service.resources.maps).
    assert set(schemas.PlanCreate.model_fields) - {"map_id"} <= set(schemas.MapCreate.model_fields)
    simulate = set(get_type_hints(SimulateFields)) | {"start", "goal"}
    assert simulate == set(schemas.SimulationCreate.model_fields)
    step = set(get_type_hints(StepFields)) | {"dynamic_obstacles"}
    assert step == set(schemas.StepCreate.model_fields)
    mapf = set(get_type_hints(MapfFields)) | {"agents"}
    assert mapf == set(schemas.MapfCreate.model_fields)
    zones = set(get_type_hints(ZonesFields))
    assert zones == set(schemas.ZonesCreate.model_fields) - {"image"}  # the YAML's image is read
    route = set(get_type_hints(RouteFields))
    assert route - plan_fields == {"waypoints", "fleet", "name"}
    plan = set(inspect.signature(PlannerClient.plan).parameters) - {"self", "options"}
    assert plan | route == set(schemas.PlanCreate.model_fields)


def test_both_clients_have_the_same_methods() -> None:
    public = {n for n in vars(PlannerClient) if not n.startswith("_")} - {"close"}
    answers = {n: get_type_hints(getattr(PlannerClient, n))["return"] for n in public}
    models = {n for n, kind in answers.items() if _models(kind)}
    assert models == set(ROUTES), "every method answering a model is checked against its route"
    assert public == {n for n in vars(AsyncPlannerClient) if not n.startswith("_")} - {"aclose"}
    for name in public:
        ours = inspect.signature(getattr(PlannerClient, name))
        assert ours == inspect.signature(getattr(AsyncPlannerClient, name)), name


def test_each_method_takes_its_routes_query_parameters(app: FastAPI) -> None:
    """A query parameter a route takes is a keyword of its method (``fleet(ahead=)``,
    ``passages(robot_radius=, max_width=)``, ``path(frame_id=)``)."""
    spec = app.openapi()
    for name, (method, path) in ROUTES.items():
        taken = {
            p["name"] for p in spec["paths"][path][method].get("parameters", ())
            if p["in"] == "query"
        }  # fmt: skip
        assert taken <= set(inspect.signature(getattr(PlannerClient, name)).parameters), name


def test_a_fleet_is_read_with_its_paths_ahead_on_request() -> None:
    asked: list[httpx.URL] = []

    def answer(request: httpx.Request) -> httpx.Response:
        asked.append(request.url)
        return httpx.Response(200, json=_example(schemas.FleetPublic))

    with PlannerClient("http://planner", transport=httpx.MockTransport(answer)) as planner:
        assert planner.fleet("warehouse-a").fleet == "warehouse-a"
        planner.fleet("warehouse-a", ahead=True)
    assert [str(u) for u in asked] == [
        "http://planner/fleets/warehouse-a",
        "http://planner/fleets/warehouse-a?ahead=true",
    ]

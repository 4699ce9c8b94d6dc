"""A table of bad requests: each gets a 4xx whose ``detail`` names the field and the value."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest
from pydantic import BaseModel, ConfigDict, ValidationError

from schemas import StepCreate
from schemas.points import STRICT, Obstacle
from service.main import create_app
from tests.service.conftest import SMALL, running

pytestmark = pytest.mark.anyio


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture(scope="module")
async def client() -> AsyncIterator[httpx.AsyncClient]:
    """One app for the whole table: no case changes what another case sees."""
    app = create_app(SMALL)
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://service") as c:
            yield c


ROWS = ["......", ".@@...", "......", "...@..", "......"]
WALLED = ["..@..", "..@..", "..@.."]
CORRIDOR = ["........", "........", "@@@.@@@@", "........", "........"]
OK = {"start": [0, 0], "goal": [4, 5]}
INFO = {"resolution": 0.05, "width": 3, "height": 2, "origin": {"position": {"x": 0.0, "y": 0.0}}}

# (name, method, url, json body or raw bytes, status, substrings of detail)
CASES: list[tuple[str, str, str, Any, int, list[str]]] = [
    ("ragged grid", "POST", "/maps", {"grid": [[0, 0], [0]]}, 422,
     ["grid", "rectangular", "grid[1] has 1 cells; grid[0] has 2"]),
    ("empty grid", "POST", "/maps", {"grid": []}, 422, ["grid", "(0,)"]),
    ("empty rows of grid", "POST", "/maps", {"grid": [[], []]}, 422, ["grid", "(2, 0)"]),
    ("cell 2", "POST", "/maps", {"grid": [[0, 2]]}, 422, ["grid", "found 2 at [0, 1]"]),
    ("cell 0.5", "POST", "/maps", {"grid": [[0, 0.5]]}, 422, ["grid[0][1]", "0.5"]),
    ("cell text", "POST", "/maps", {"grid": [[0, "a"]]}, 422, ["grid[0][1]", "'a'"]),
    ("unknown letter", "POST", "/maps", {"rows": ["..x"]}, 422, ["rows[0]", "'x'", "column 2"]),
    ("non-ascii letter", "POST", "/maps", {"rows": [".é"]}, 422, ["rows[0]", "'é'"]),
    ("ragged rows", "POST", "/maps", {"rows": ["...", ".."]}, 422, ["rows[1]", "2 characters"]),
    ("empty rows", "POST", "/maps", {"rows": []}, 422, ["rows", "empty"]),
    ("both encodings", "POST", "/maps", {"grid": [[0]], "rows": ["."]}, 422, ["grid", "rows", "exactly one"]),
    ("neither encoding", "POST", "/maps", {"start": [0, 0]}, 422, ["grid", "rows", "neither"]),
    ("start without goal", "POST", "/maps", {"rows": ROWS, "start": [0, 0]}, 422, ["'goal'"]),
    ("too many cells", "POST", "/maps", {"rows": ["." * 65] * 65}, 413, ["rows", "65 x 65", "4225", "4096"]),
    ("body too large", "POST", "/maps", {"rows": ["." * 60] * 1200}, 413, ["body", "bytes", "65536"]),
    ("too large, not even parsed", "POST", "/maps", b"{" * 70000, 413, ["body", "70000 bytes"]),
    ("malformed JSON", "POST", "/plan", b'{"map_id": "x", "start": [0', 422, ["JSON", "character"]),
    ("body not an object", "POST", "/plan", [1, 2], 422, ["body", "[1, 2]"]),
    ("start too short", "POST", "/plan", {"map_id": "{map}", "start": [0], "goal": [4, 5]}, 422, ["start", "[0]"]),
    ("goal too long", "POST", "/plan", {"map_id": "{map}", "start": [0, 0], "goal": [1, 2, 3]}, 422, ["goal", "[1, 2, 3]"]),
    ("start not numbers", "POST", "/plan", {"map_id": "{map}", "start": ["a", 0], "goal": [4, 5]}, 422, ["start[0]", "'a'"]),
    ("start negative", "POST", "/plan", {"map_id": "{map}", "start": [-1, 0], "goal": [4, 5]}, 422, ["start[0]", "-1"]),
    ("start outside", "POST", "/plan", {"map_id": "{map}", "start": [5, 0], "goal": [4, 5]}, 422, ["start [5, 0]", "outside"]),
    ("goal outside", "POST", "/plan", {"map_id": "{map}", "start": [0, 0], "goal": [0, 6]}, 422, ["goal [0, 6]", "outside"]),
    ("start on obstacle", "POST", "/plan", {"map_id": "{map}", "start": [1, 1], "goal": [4, 5]}, 422, ["start [1, 1]", "obstacle"]),
    ("goal on obstacle", "POST", "/plan", {"map_id": "{map}", "start": [0, 0], "goal": [3, 3]}, 422, ["goal [3, 3]", "obstacle"]),
    ("unknown preset", "POST", "/plan", {"map_id": "{map}", **OK, "preset": "fast"}, 422, ["preset", "'fast'"]),
    ("unknown parameter", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"gamma": 1}}, 422, ["params.gamma", "'gamma'"]),
    ("alpha out of range", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"alpha": 99}}, 422, ["alpha", "99"]),
    ("max_detour below 1", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"max_detour": 0.9}}, 422, ["max_detour must be a finite number", "0.9", "shortest route"]),
    ("max_detour too big", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"max_detour": 1000}}, 422, ["max_detour", "finite number from 1 to 100", "1000"]),
    ("max_detour mistyped", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"max_detour": "1.5"}}, 422, ["max_detour must be a number", "'1.5'"]),
    ("rho is no parameter", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"rho": 0.5}}, 422, ["rho is not a parameter"]),
    ("radius not an integer", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"clean_radius": 1.5}}, 422, ["clean_radius", "1.5"]),
    ("seal_tunnels mistyped", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"seal_tunnels": "yes"}}, 422, ["seal_tunnels", "'yes'"]),
    ("params not an object", "POST", "/plan", {"map_id": "{map}", **OK, "params": [1]}, 422, ["params", "[1]"]),
    ("allow_narrow mistyped", "POST", "/plan", {"map_id": "{map}", **OK, "allow_narrow": "maybe"}, 422, ["allow_narrow", "'maybe'"]),
    ("huge integer", "POST", "/plan", b'{"map_id": "m", "start": [0, 99999999999999999999999], "goal": [0, 0]}', 422, ["start[1]", "1e+23"]),
    ("unreachable goal", "POST", "/plan", {"map_id": "{walled}", "start": [0, 0], "goal": [0, 4]}, 422, ["goal", "NO_VALID_PATH", "[0, 4]"]),
    ("narrow refused", "POST", "/plan", {"map_id": "{corridor}", "start": [0, 3], "goal": [4, 3], "allow_narrow": False}, 422, ["NO_VALID_PATH", "tight tunnels"]),
    ("unknown map for a plan", "POST", "/plan", {"map_id": "nope", **OK}, 404, ["map_id", "'nope'"]),
    ("unknown map", "GET", "/maps/nope", None, 404, ["map_id", "'nope'"]),
    ("unknown map to simulate", "POST", "/maps/nope/simulate", OK, 404, ["map_id", "'nope'"]),
    ("unknown plan", "GET", "/plan/nope", None, 404, ["plan_id", "'nope'"]),
    ("unknown plan to delete", "DELETE", "/plan/nope", None, 404, ["plan_id", "'nope'"]),
    ("unknown plan to step", "POST", "/plan/nope/step", {}, 404, ["plan_id", "'nope'"]),
    ("obstacle outside", "POST", "/plan/{plan}/step", {"dynamic_obstacles": [[0, 0], [50, 0]]}, 422, ["dynamic_obstacles[1]", "[50, 0]", "outside"]),
    ("obstacle malformed", "POST", "/plan/{plan}/step", {"dynamic_obstacles": [[1]]}, 422, ["dynamic_obstacles[0]", "[1]"]),
    ("obstacles not a list", "POST", "/plan/{plan}/step", {"dynamic_obstacles": "here"}, 422, ["dynamic_obstacles", "'here'"]),
    ("too many obstacles", "POST", "/plan/{plan}/step", {"dynamic_obstacles": [[0, 1]] * 21}, 422, ["dynamic_obstacles", "21", "20"]),
    ("position outside", "POST", "/plan/{plan}/step", {"position": [9, 9]}, 422, ["position [9, 9]", "outside"]),
    ("position on obstacle", "POST", "/plan/{plan}/step", {"position": [1, 2]}, 422, ["position [1, 2]", "obstacle"]),
    ("seq negative", "POST", "/plan/{plan}/step", {"seq": -1}, 422, ["seq", "-1"]),
    ("seq gap", "POST", "/plan/{stepped}/step", {"seq": 3}, 409, ["seq 3", "seq 1"]),
    ("seq behind", "POST", "/plan/{stepped}/step", {"seq": 0}, 409, ["seq 0", "seq 1"]),
    ("too many simulated", "POST", "/maps/{map}/simulate", {**OK, "dynamic_count": 21}, 422, ["dynamic_count", "21"]),
    ("more than free cells", "POST", "/maps/{walled}/simulate", {"start": [0, 0], "goal": [2, 0], "dynamic_count": 20}, 422, ["dynamic_count", "20"]),
    ("max_steps zero", "POST", "/maps/{map}/simulate", {**OK, "max_steps": 0}, 422, ["max_steps", "0"]),
    ("seed mistyped", "POST", "/maps/{map}/simulate", {**OK, "seed": "x"}, 422, ["seed", "'x'"]),
    # Strict: unknown fields are refused, and nothing is coerced.
    ("unknown field in a step", "POST", "/plan/{plan}/step", {"obstacles": [[1, 1]]}, 422, ["obstacles", "unknown field"]),
    ("unknown field in a plan", "POST", "/plan", {"map_id": "{map}", **OK, "colour": "red"}, 422, ["colour", "unknown field"]),
    ("unknown field in a map", "POST", "/maps", {"rows": ROWS, "label": "hall"}, 422, ["label", "unknown field"]),
    ("unknown field to simulate", "POST", "/maps/{map}/simulate", {**OK, "dynamic": 3}, 422, ["dynamic", "unknown field"]),
    ("goal of booleans", "POST", "/plan", {"map_id": "{map}", "start": [0, 0], "goal": [False, 0]}, 422, ["goal[0]", "False"]),
    ("start of strings", "POST", "/plan", {"map_id": "{map}", "start": ["0", "0"], "goal": [4, 5]}, 422, ["start[0]", "'0'"]),
    ("start of floats", "POST", "/plan", {"map_id": "{map}", "start": [0.0, 0.0], "goal": [4, 5]}, 422, ["start[0]", "0.0"]),
    ("seq boolean", "POST", "/plan/{plan}/step", {"seq": True}, 422, ["seq", "True"]),
    ("seq float", "POST", "/plan/{plan}/step", {"seq": 1.0}, 422, ["seq", "1.0"]),
    ("position of floats", "POST", "/plan/{plan}/step", {"position": [0.0, 1]}, 422, ["position[0]", "0.0"]),
    ("obstacle of strings", "POST", "/plan/{plan}/step", {"dynamic_obstacles": [["1", "1"]]}, 422, ["dynamic_obstacles[0][0]", "'1'"]),
    ("grid of booleans", "POST", "/maps", {"grid": [[True, False]]}, 422, ["grid[0][0]", "True"]),
    ("dynamic_count float", "POST", "/maps/{map}/simulate", {**OK, "dynamic_count": 2.0}, 422, ["dynamic_count", "2.0"]),
    # Unknown query parameters are refused too, on every API route (probes aside).
    ("unknown query on a picture", "GET", "/maps/{map}/render.png?cel=4", None, 422, ["'cel'", "unknown query parameter", "cell"]),
    ("unknown query on a plan picture", "GET", "/plan/{plan}/render.png?feild=kw", None, 422, ["'feild'", "field"]),
    ("unknown query on a step", "POST", "/plan/{plan}/step?seq=1", {}, 422, ["'seq'", "takes: none"]),
    ("unknown query on a plan", "POST", "/plan?preset=wide", {"map_id": "{map}", **OK}, 422, ["'preset'", "unknown query parameter"]),
    ("unknown query on a read", "GET", "/plan/{plan}?verbose=1", None, 422, ["'verbose'"]),
    ("allow_narrow integer", "POST", "/plan", {"map_id": "{map}", **OK, "allow_narrow": 1}, 422, ["allow_narrow", "1"]),
    ("preset not text", "POST", "/plan", {"map_id": "{map}", **OK, "preset": 1}, 422, ["preset", "1"]),
    # Robot maps (API.md "Robot maps in meters"); bad YAML + image uploads: test_robot_maps.py.
    ("data length", "POST", "/maps", {"occupancy_grid": {"info": INFO, "data": [0] * 5}}, 422, ["occupancy_grid.data", "5 values", "3 x 2 = 6"]),
    ("data value", "POST", "/maps", {"occupancy_grid": {"info": INFO, "data": [0, 0, 101, 0, 0, 0]}}, 422, ["occupancy_grid.data", "101", "index 2"]),
    ("data value -2", "POST", "/maps", {"occupancy_grid": {"info": INFO, "data": [0, -2, 0, 0, 0, 0]}}, 422, ["occupancy_grid.data", "-2"]),
    ("no info", "POST", "/maps", {"occupancy_grid": {"data": []}}, 422, ["occupancy_grid", "'info'"]),
    ("zero resolution", "POST", "/maps", {"occupancy_grid": {"info": {**INFO, "resolution": 0}, "data": [0] * 6}}, 422, ["occupancy_grid.info.resolution", "0"]),
    ("width of text", "POST", "/maps", {"occupancy_grid": {"info": {**INFO, "width": "3"}, "data": [0] * 6}}, 422, ["occupancy_grid.info.width", "'3'"]),
    ("cells by the header", "POST", "/maps", {"occupancy_grid": {"info": {**INFO, "width": 100, "height": 100}, "data": []}}, 413, ["occupancy_grid", "100 x 100", "10000", "4096"]),
    ("grid resolution negative", "POST", "/maps", {"grid": [[0, -1]], "resolution": -0.1}, 422, ["resolution", "-0.1"]),
    ("grid origin of two", "POST", "/maps", {"grid": [[0, -1]], "origin": [1.0, 2.0]}, 422, ["origin", "[1.0, 2.0]"]),
    ("grid cell -2", "POST", "/maps", {"grid": [[0, -2]]}, 422, ["grid", "found -2 at [0, 1]"]),
    ("frame with an OccupancyGrid", "POST", "/maps", {"occupancy_grid": {"info": INFO, "data": [0] * 6}, "resolution": 1.0}, 422, ["resolution", "own"]),
    ("two maps", "POST", "/maps", {"grid": [[0]], "occupancy_grid": {"info": INFO, "data": [0] * 6}}, 422, ["exactly one", "grid and occupancy_grid"]),
    ("point without y", "POST", "/plan", {"map_id": "{map}", "start": {"x": 0.5}, "goal": [4, 5]}, 422, ["start.y", "Field required"]),
    ("point with z", "POST", "/plan", {"map_id": "{map}", "start": {"x": 0.5, "y": 0.5, "z": 0}, "goal": [4, 5]}, 422, ["start.z", "unknown field"]),
    ("point of text", "POST", "/plan", {"map_id": "{map}", "start": {"x": "0.5", "y": 0.5}, "goal": [4, 5]}, 422, ["start.x", "'0.5'"]),
    ("point outside", "POST", "/plan", {"map_id": "{map}", "start": {"x": 0.5, "y": 0.5}, "goal": {"x": 9.5, "y": 0.5}}, 422, ["goal", "9.5", "outside the map", "resolution 1"]),
    ("point on obstacle", "POST", "/plan", {"map_id": "{map}", "start": {"x": 1.5, "y": 3.5}, "goal": [4, 5]}, 422, ["start", "(cell [1, 1])", "obstacle"]),
    ("robot_radius negative", "POST", "/plan", {"map_id": "{map}", **OK, "robot_radius": -0.1}, 422, ["robot_radius", "-0.1"]),
    ("robot_radius text", "POST", "/plan", {"map_id": "{map}", **OK, "robot_radius": "big"}, 422, ["robot_radius", "'big'"]),
    ("robot_radius twice", "POST", "/plan", {"map_id": "{map}", **OK, "robot_radius": 0.2, "params": {"robot_radius": 0.3}}, 422, ["robot_radius", "0.2", "0.3", "disagree"]),
    ("unknown policy", "POST", "/maps/{map}/simulate", {**OK, "unknown": "maybe"}, 422, ["unknown", "'maybe'"]),
    ("unknown policy in params", "POST", "/plan", {"map_id": "{map}", **OK, "params": {"unknown": "maybe"}}, 422, ["unknown must be 'blocked' or 'free'", "'maybe'"]),
    ("start occupied by the radius", "POST", "/plan", {"map_id": "{map}", **OK, "robot_radius": 1.0}, 422, ["START_OCCUPIED", "start [0, 0]", "robot_radius 1"]),
    ("circle outside", "POST", "/plan/{plan}/step", {"dynamic_obstacles": [{"x": 1.0, "y": 1.0, "radius": 0.5}, {"x": 50.0, "y": 1.0, "radius": 0.5}]}, 422, ["dynamic_obstacles[1]", "entirely outside the map", "x [0, 6], y [0, 5]"]),
    ("circle without radius", "POST", "/plan/{plan}/step", {"dynamic_obstacles": [{"x": 1.0, "y": 1.0}]}, 422, ["dynamic_obstacles[0].radius", "Field required"]),
    ("circle radius negative", "POST", "/plan/{plan}/step", {"dynamic_obstacles": [{"x": 1.0, "y": 1.0, "radius": -1}]}, 422, ["dynamic_obstacles[0].radius", "-1"]),
    ("position yaw text", "POST", "/plan/{plan}/step", {"position": {"x": 0.5, "y": 4.5, "yaw": "north"}}, 422, ["position.yaw", "'north'"]),
    ("position yaw boolean", "POST", "/plan/{plan}/step", {"position": {"x": 0.5, "y": 4.5, "yaw": True}}, 422, ["position.yaw", "True"]),
    ("position yaw infinite", "POST", "/plan/{plan}/step", b'{"position": {"x": 0.5, "y": 4.5, "yaw": 1e999}}', 422, ["position.yaw", "inf"]),
    ("yaw on a cell", "POST", "/plan/{plan}/step", {"position": [0, 0, 1.0]}, 422, ["position", "[0, 0, 1.0]"]),
    ("circle with extra", "POST", "/plan/{plan}/step", {"dynamic_obstacles": [{"x": 1.0, "y": 1.0, "radius": 1, "z": 0}]}, 422, ["dynamic_obstacles[0].z", "unknown field"]),
    ("position point outside", "POST", "/plan/{plan}/step", {"position": {"x": -1.0, "y": 0.5}}, 422, ["position", "-1.0", "outside the map"]),
]  # fmt: skip


@pytest.fixture(scope="module")
async def ids(client: httpx.AsyncClient) -> dict[str, str]:
    out = {}
    for name, rows in (("map", ROWS), ("walled", WALLED), ("corridor", CORRIDOR)):
        out[name] = (await client.post("/maps", json={"rows": rows})).json()["map_id"]
    for name in ("plan", "stepped"):
        r = await client.post("/plan", json={"map_id": out["map"], **OK})
        out[name] = r.json()["plan_id"]
    # The first step's seq may be any; later steps must follow it.
    for seq in (0, 1):
        r = await client.post(f"/plan/{out['stepped']}/step", json={"seq": seq})
        assert r.status_code == 200
    return out


def _fill(value: Any, ids: dict[str, str]) -> Any:
    if isinstance(value, str):
        return value.format(**ids)
    if isinstance(value, dict):
        return {k: _fill(v, ids) for k, v in value.items()}
    return value


@pytest.mark.parametrize(
    ("method", "url", "body", "status", "named"),
    [case[1:] for case in CASES],
    ids=[case[0] for case in CASES],
)
async def test_bad_request_is_refused_and_named(
    client: httpx.AsyncClient,
    ids: dict[str, str],
    method: str,
    url: str,
    body: Any,
    status: int,
    named: list[str],
) -> None:
    headers = {"content-type": "application/json"}
    if isinstance(body, bytes):
        r = await client.request(method, url.format(**ids), content=body, headers=headers)
    elif body is None:
        r = await client.request(method, url.format(**ids))
    else:
        r = await client.request(method, url.format(**ids), json=_fill(body, ids))
    assert r.status_code == status, r.text
    detail = r.json()["detail"]
    assert isinstance(detail, str)
    for text in named:
        assert text in detail, f"{text!r} not in {detail!r}"


@pytest.mark.parametrize(
    ("method", "url", "body"),
    [
        ("POST", "/plan/{plan}/step", {"x" * 30_000: 1}),
        ("POST", "/plan", {"map_id": "m" * 30_000, **OK}),
        ("POST", "/plan", {"map_id": "{map}", **OK, "params": {"p" * 30_000: 1}}),
        ("POST", "/plan", {"map_id": "{map}", **OK, "preset": "w" * 30_000}),
        ("GET", "/plan/" + "q" * 16_000, None),
        ("POST", "/maps", {"rows": ["." * 50, "é" * 50]}),
    ],
    ids=["field name", "map_id", "parameter name", "preset", "plan id", "map row"],
)
async def test_errors_quote_at_most_100_characters_of_a_value(
    client: httpx.AsyncClient, ids: dict[str, str], method: str, url: str, body: Any
) -> None:
    r = await client.request(method, url.format(**ids), json=_fill(body, ids))
    assert r.status_code in (404, 422), r.text
    error = r.json()
    assert len(error["detail"]) < 400, error["detail"]
    assert error["field"] is None or len(error["field"]) <= 100


async def test_streamed_body_over_the_limit_is_refused(client: httpx.AsyncClient) -> None:
    async def chunks() -> AsyncIterator[bytes]:
        for _ in range(100):
            yield b"[" * 1000

    r = await client.post("/maps", content=chunks(), headers={"content-type": "application/json"})
    assert r.status_code == 413
    assert "body" in r.json()["detail"]


async def test_streamed_body_under_the_limit_is_served(client: httpx.AsyncClient) -> None:
    body = b'{"rows": ["...", "..."]}'

    async def chunks() -> AsyncIterator[bytes]:
        for i in range(0, len(body), 5):
            yield body[i : i + 5]

    r = await client.post("/maps", content=chunks(), headers={"content-type": "application/json"})
    assert r.status_code == 201
    assert r.json()["height"] == 2


@pytest.mark.parametrize(
    "body",
    [{"rows": ["." * 100] * 100}, {"grid": [[0, 1] * 50] * 100}],
    ids=["rows", "grid"],
)
async def test_a_map_far_over_the_cell_limit_is_refused_unparsed(
    client: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch, body: dict[str, Any]
) -> None:
    from service.api import deps

    async def never(self: Any) -> Any:
        raise AssertionError("the body was parsed")

    monkeypatch.setattr(deps._OrjsonRequest, "json", never)
    r = await client.post("/maps", json=body)  # 10000 cells; the test limit is 4096
    assert r.status_code == 413, r.text
    assert "about 10000 map cells" in r.json()["detail"]
    assert "refused before parsing" in r.json()["detail"]


async def test_an_occupancy_grid_far_over_the_cell_limit_is_refused_unparsed(
    client: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    from service.api import deps

    async def never(self: Any) -> Any:
        raise AssertionError("the body was parsed")

    monkeypatch.setattr(deps._OrjsonRequest, "json", never)
    info = {**INFO, "width": 100, "height": 100}
    r = await client.post("/maps", json={"occupancy_grid": {"info": info, "data": [100] * 10_000}})
    assert r.status_code == 413, r.text
    assert "refused before parsing" in r.json()["detail"]


async def test_an_occupancy_grid_of_hundreds_at_the_limit_is_served(
    client: httpx.AsyncClient,
) -> None:
    # 4096 values of 100: 12288 digits, more than the limit, but 4095 commas: served.
    info = {**INFO, "width": 64, "height": 64}
    r = await client.post("/maps", json={"occupancy_grid": {"info": info, "data": [100] * 4096}})
    assert r.status_code == 201, r.text
    assert r.json()["occupied_cells"] == 4096


async def test_a_map_at_the_cell_limit_is_served(client: httpx.AsyncClient) -> None:
    r = await client.post(
        "/maps", json={"grid": [[0] * 64] * 64, "start": [0, 0], "goal": [63, 63]}
    )
    assert r.status_code == 201, r.text


@pytest.mark.parametrize(
    ("method", "url", "status", "code"),
    [
        ("GET", "/no/such/route", 404, "NOT_FOUND"),
        ("PUT", "/plan", 405, "METHOD_NOT_ALLOWED"),
    ],
)
async def test_the_frameworks_own_errors_have_the_one_error_shape(
    client: httpx.AsyncClient, method: str, url: str, status: int, code: str
) -> None:
    r = await client.request(method, url)
    assert r.status_code == status
    assert r.json()["code"] == code
    assert set(r.json()) == {"detail", "field", "code"}


@pytest.mark.parametrize(
    ("content", "files"),
    [
        # A part whose header is cut by a stray line: the form cannot be parsed.
        (b"--b\r\n-85312991875--b--\r\n", None),
        (None, [("yaml", b"a: 1"), ("image", b"P5"), ("yaml", b"b: 2")]),  # a part too many
    ],
    ids=["malformed", "too many parts"],
)
async def test_a_bad_multipart_form_is_a_422(
    client: httpx.AsyncClient, content: bytes | None, files: list[tuple[str, bytes]] | None
) -> None:
    if content is not None:
        headers = {"content-type": "multipart/form-data; boundary=b"}
        r = await client.post("/maps", content=content, headers=headers)
    else:
        assert files is not None
        r = await client.post("/maps", files=[(n, (n, data)) for n, data in files])
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "body"
    assert "multipart" in r.json()["detail"]


OBSTACLES: list[Any] = [
    [],
    [[0, 0], [2**31 - 1, 7]],
    [[0, 0], [2**31, 7]],
    [[-1, 0]],
    [[1, True]],
    [[1.0, 2]],
    [[1, 2, 3]],
    [[1]],
    [(1, 2)],
    [[1, 2], {"x": 0.5, "y": 0.5, "radius": 0.1}],
    [{"x": 0.5, "y": 0.5}],
    [[1, 2], "3,4"],
    "[[1, 2]]",
    None,
]


class _ItemByItem(BaseModel):
    model_config = ConfigDict(**STRICT)
    dynamic_obstacles: list[Obstacle]


@pytest.mark.parametrize("given", OBSTACLES)
def test_obstacles_checked_at_once_validate_as_item_by_item(given: Any) -> None:
    """``StepCreate``'s one-pass check of cells answers what pydantic's own validation of
    ``list[Obstacle]`` answers: the same value, or the same errors."""

    def outcome(model: type[BaseModel]) -> Any:
        try:
            return model.model_validate({"dynamic_obstacles": given}).model_dump()[
                "dynamic_obstacles"
            ]
        except ValidationError as exc:
            return exc.errors(include_url=False)

    assert outcome(StepCreate) == outcome(_ItemByItem)


@pytest.mark.anyio
async def test_constraint_errors_name_the_exact_path_in_words() -> None:
    """A name against its pattern is answered in words, not a regex; a list too short names
    the item's exact path (``keepout[0]``, as the docs write it); numbers out of range say the
    bound in words."""
    import httpx

    from service.config import Settings
    from service.main import create_app

    app = create_app(Settings(pool_size=1))
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://s") as c:
            made = await c.post("/maps", json={"rows": ["....", "....", "...."]})
            map_id = made.json()["map_id"]
            plan = {"map_id": map_id, "start": [0, 0], "goal": [2, 3]}
            r = await c.post("/plan", json={**plan, "fleet": "has space"})
            assert r.json()["field"] == "fleet"
            assert "letters, digits" in r.json()["detail"]
            assert "^[" not in r.json()["detail"]
            two = [{"x": 0, "y": 0}, {"x": 1, "y": 1}]
            r = await c.post(f"/maps/{map_id}/zones", json={"keepout": [two]})
            assert r.json()["field"] == "keepout[0]"
            assert "needs at least 3 items" in r.json()["detail"]
            r = await c.post(f"/plan/{'0' * 32}/step", json={"seq": -1})
            assert r.json()["field"] == "seq"
            assert "must be at least 0" in r.json()["detail"]
            yaml = b"image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
            r = await c.post("/maps", files={"yaml": ("m.yaml", yaml)})
            assert r.status_code == 422
            assert "needs its 'image' part" in r.json()["detail"]
            assert "b'" not in r.json()["detail"]  # the part's bytes are counted, not quoted
            assert "Value error" not in r.json()["detail"]

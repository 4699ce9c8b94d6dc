"""Extreme and careless inputs against a real server (uvicorn in a process of its own, over
TCP): extreme frames, deep form fields, images over any limit, PGM values over ``maxval``, the
documentation behind API keys, and the mistakes a careless client makes, each answered with a
4xx that says what to do, never a 5xx, an object's repr or the body echoed back."""

from __future__ import annotations

import io
import re
import struct
import zlib
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from PIL import Image

from tests.service.browser import dump_dom
from tests.service.conftest import Replica, replicas

GRID = [[0] * 6 for _ in range(6)]
YAML = b"image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
PGM = b"P5 2 2 255\n" + bytes([0, 255, 255, 0])
KEY = "hostile-input-key"


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Replica]:
    directory = tmp_path_factory.mktemp("hostile-input")
    with replicas("memory://", directory, 1, {"PLANNER_API_KEYS": KEY}) as (replica,):
        yield replica


@pytest.fixture(scope="module")
def client(server: Replica) -> Iterator[httpx.Client]:
    headers = {"X-API-Key": KEY}
    with httpx.Client(base_url=server.url, trust_env=False, timeout=60, headers=headers) as c:
        yield c


def _refused(r: httpx.Response, status: int, field: str | None, *said: str) -> str:
    assert r.status_code == status, r.text
    body = r.json()
    if field is not None:
        assert body["field"] == field, body
    for text in said:
        assert text in body["detail"], (text, body["detail"])
    assert "object at 0x" not in r.text
    detail: str = body["detail"]
    return detail


def _ros(
    yaml: bytes = YAML, image: bytes = PGM, form: dict[str, str] | None = None
) -> dict[str, Any]:
    return {"files": {"yaml": ("m.yaml", yaml), "image": ("m.pgm", image)}, "data": form}


def _occupancy_grid(**info: Any) -> dict[str, Any]:
    base = {"resolution": 0.05, "width": 2, "height": 1, "origin": {"position": {"x": 0.0}}}
    return {"info": {**base, **info}, "data": [0, 0]}


# L1: extreme frames


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"grid": GRID, "resolution": 1e308}, "resolution"),
        ({"grid": GRID, "resolution": 1e-300}, "resolution"),
        ({"grid": GRID, "resolution": 5e-324}, "resolution"),
        ({"grid": GRID, "origin": [1e308, 1e308, 0]}, "origin"),
        ({"rows": ["......"] * 6, "origin": [-1e7, 0, 0]}, "origin"),
        ({"occupancy_grid": _occupancy_grid(resolution=1e-300)}, "occupancy_grid.info.resolution"),
        (
            {"occupancy_grid": _occupancy_grid(origin={"position": {"x": 1e308, "y": 1e308}})},
            "occupancy_grid.info.origin",
        ),
    ],
)
def test_an_extreme_frame_is_refused_at_upload(
    client: httpx.Client, body: dict[str, Any], field: str
) -> None:
    """Each of these was stored, and its first step, render or plan answered 500 (a step even
    moved the robot before its answer failed)."""
    _refused(client.post("/maps", json={**body, "start": [0, 0], "goal": [0, 1]}), 422, field)
    _refused(client.post("/maps", json=body), 422, field)


def test_an_extreme_ros_frame_is_refused_at_upload(client: httpx.Client) -> None:
    for yaml, field in [
        (b"image: m.pgm\nresolution: 1e308\norigin: [0, 0, 0]\n", "yaml.resolution"),
        (b"image: m.pgm\nresolution: 5e-324\norigin: [0, 0, 0]\n", "yaml.resolution"),
        (b"image: m.pgm\nresolution: 0.05\norigin: [1e308, 1e308, 0]\n", "yaml.origin"),
    ]:
        _refused(client.post("/maps", **_ros(yaml)), 422, field)


def test_a_frame_at_the_bounds_steps_and_renders(client: httpx.Client) -> None:
    body = {"grid": GRID, "resolution": 1e-4, "start": [0, 0], "goal": [5, 5]}
    far = {"grid": GRID, "resolution": 1e3, "origin": [-9.99e6, 9.99e6, 0.5]}
    for upload in (body, {**far, "start": [0, 0], "goal": [5, 5]}):
        r = client.post("/maps", json=upload)
        assert r.status_code in (200, 201), r.text
        plan_id, map_id = r.json()["plan"]["plan_id"], r.json()["map_id"]
        res = upload["resolution"]
        x, y = client.get(f"/plan/{plan_id}").json()["position_xy"]
        circle = {"x": x + 2 * res, "y": y, "radius": res}  # type: ignore[operator]
        for obstacles in ([], [circle]):
            r = client.post(f"/plan/{plan_id}/step", json={"dynamic_obstacles": obstacles})
            assert r.status_code == 200, r.text
        assert client.get(f"/maps/{map_id}/render.png").status_code == 200
        assert client.get(f"/plan/{plan_id}/render.png").status_code == 200
        assert client.get(f"/plan/{plan_id}/path").status_code == 200


# L2: every form field checked for depth


@pytest.mark.parametrize("name", ["params", "start", "waypoints", "goal"])
def test_a_deep_form_field_is_refused_unparsed(client: httpx.Client, name: str) -> None:
    deep = {"params": '{"alpha": ' + "[" * 1000 + "]" * 1000 + "}"}.get(name, "[" * 1000)
    form = {"start": "[0, 0]", "goal": "[1, 1]", name: deep}
    _refused(client.post("/maps", **_ros(form=form)), 422, name, "levels deep", "64")


# L3 and L5: images


def _png_header(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")


def test_an_image_over_any_limit_is_413_from_its_header(client: httpx.Client) -> None:
    out = io.BytesIO()
    Image.new("1", (20000, 20000)).save(out, format="PNG")  # a real one, 400 M pixels
    for image in (out.getvalue(), _png_header(100000, 100000), _png_header(5000, 5000)):
        _refused(client.post("/maps", **_ros(image=image)), 413, "image")


def test_a_pgm_value_above_its_maxval_is_refused(client: httpx.Client) -> None:
    image = b"P5 2 2 100\n" + bytes([0, 255, 100, 0])
    _refused(client.post("/maps", **_ros(image=image)), 422, "image", "255", "maxval 100")
    image = b"P5 2 2 100\n" + bytes([0, 50, 100, 0])  # within it: read as its shades
    assert client.post("/maps", **_ros(image=image)).status_code in (200, 201)


def test_no_error_names_an_object(client: httpx.Client) -> None:
    full = io.BytesIO()
    Image.effect_noise((64, 64), 60).convert("L").save(full, format="PNG")
    cut = full.getvalue()[: len(full.getvalue()) // 2]  # its pixels end early
    images = [b"garbage!!", b"", cut, b"P5 2 2 255\n", b"BM" + b"\0" * 60]
    images += [b"GIF89a" + b"\xff" * 20, b"\x89PNG\r\n\x1a\n" + b"\0" * 30]
    yamls = [b"image: [", b"- 1\n- 2", b"resolution: x\norigin: [0,0,0]", b"\xff\xfe"]
    answers = [client.post("/maps", **_ros(image=image)) for image in images]
    answers += [client.post("/maps", **_ros(yaml=yaml)) for yaml in yamls]
    answers += [
        client.post("/maps", json={"occupancy_grid": {"info": object.__name__, "data": 1}}),
        client.post("/maps", files={"yaml": ("m.yaml", YAML), "image": ("m.pgm", b"\0" * 10)}),
    ]
    for r in answers:
        assert 400 <= r.status_code < 500, r.text
        assert not re.search(r"object at 0x|at 0x[0-9a-f]{6,}", r.text), r.text


# L4: the documentation behind API keys


def test_the_docs_render_with_api_keys_set(server: Replica) -> None:
    with httpx.Client(base_url=server.url, trust_env=False) as anonymous:
        assert anonymous.post("/plan", json={}).status_code == 401  # the API still needs a key
        for page in ("/docs", "/redoc"):
            html = anonymous.get(page).text
            for link in re.findall(r"""\b(?:src|href)\s*=\s*["']([^"']+)""", html):
                assert anonymous.get(link).status_code == 200, link
        assert anonymous.get("/docs/static/../plan/x").status_code != 200
    dom = dump_dom(f"{server.url}/docs", budget_ms=20_000)
    assert "/plan/{plan_id}/step" in dom  # the page's script ran: its assets came


# Careless users


@pytest.mark.parametrize(
    "url", ["/plan", "/maps", "/maps/{map_id}/simulate", "/plan/{plan_id}/step"]
)
@pytest.mark.parametrize("content_type", ["application/x-www-form-urlencoded", "text/plain", None])
def test_a_json_body_without_its_content_type_is_told_to_send_one(
    client: httpx.Client, url: str, content_type: str | None
) -> None:
    """``curl -d @plan.json`` sends ``application/x-www-form-urlencoded``."""
    r = client.post("/maps", json={"grid": GRID, "start": [0, 0], "goal": [5, 5]})
    ids = {"map_id": r.json()["map_id"], "plan_id": r.json()["plan"]["plan_id"]}
    headers = {} if content_type is None else {"content-type": content_type}
    body = b'{"map_id": "%s", "start": [0, 0], "goal": [1, 1]}' % ids["map_id"].encode()
    r = client.post(url.format(**ids), content=body, headers=headers)
    detail = _refused(r, 422, "content-type", "Content-Type: application/json")
    assert (content_type or "no Content-Type") in detail
    assert ids["map_id"][:20] not in detail  # the body is not echoed


def test_unknown_fields_are_named_with_the_fields_the_body_takes(client: httpx.Client) -> None:
    map_id = client.post("/maps", json={"grid": GRID}).json()["map_id"]
    r = client.post("/plan", json={"map_id": map_id, "from": [0, 0], "to": [5, 5]})
    detail = _refused(r, 422, "from", "'from', 'to'", "start, goal", "map_id", "waypoints")
    assert "[0, 0]" not in detail  # the body not echoed
    assert map_id[:12] not in detail
    r = client.post(f"/maps/{map_id}/simulate", json={"from": [0, 0], "goal": [5, 5]})
    _refused(r, 422, "from", "'from'", "dynamic_count", "start")
    plan_id = client.post("/plan", json={"map_id": map_id, "start": [0, 0], "goal": [5, 5]})
    r = client.post(f"/plan/{plan_id.json()['plan_id']}/step", json={"obstacles": []})
    _refused(r, 422, "obstacles", "'obstacles'", "dynamic_obstacles")


@pytest.mark.parametrize("part", ["file", "map"])
def test_a_multipart_map_under_another_name_is_told_the_parts(
    client: httpx.Client, part: str
) -> None:
    files = {part: ("m.yaml", YAML), "image": ("m.pgm", PGM)}
    _refused(client.post("/maps", files=files), 422, part, "'yaml'", "'image'")
    files = {part: ("m.yaml", YAML)}
    _refused(client.post("/maps", files=files), 422, part, "'yaml'", "'image'")

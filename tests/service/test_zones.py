"""``POST /maps/{map_id}/zones`` over HTTP: keepout polygons and a Nav2 keepout mask over the
shared ``depot`` map, plans on the zoned map never entering a keepout cell (robot radius
applied) over 20 seeded pairs whose unzoned route crosses the zone, the base map unchanged,
ids, tenants, and every bad request naming its field."""

from __future__ import annotations

import io
import itertools
import math
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from fastapi import FastAPI
from PIL import Image
from pydantic import SecretStr

import planner
from planner.maps.polygons import polygon_cells
from service.config import Settings
from tests.service.conftest import SMALL, running
from tests.service.test_robot_maps import multipart, ros_files

pytestmark = pytest.mark.anyio

RADIUS = 0.22
# The middle of the depot's racks (x 13..17 m, y 3..12 m): routes across the hall cross it,
# and the aisles above and below it stay open.
ZONE = [(13.0, 3.0), (17.0, 3.0), (17.0, 12.0), (13.0, 12.0)]
BIG = Settings(pool_size=2)
BOWTIE = [(1, 1), (3, 3), (3, 1), (1, 3)]
FAR = [(100, 100), (101, 100), (101, 101)]
SLOW = [(2.0, 5.5), (9.0, 5.5), (9.0, 9.5), (2.0, 9.5)]
TWO = [{"x": 2, "y": 1}, {"x": 2, "y": 2}]


def points(polygon: Any) -> list[dict[str, float]]:
    return [{"x": x, "y": y} for x, y in polygon]


@pytest.fixture
def settings() -> Settings:
    return BIG


@pytest.fixture
async def depot(client: httpx.AsyncClient, ros: Path) -> dict[str, Any]:
    r = await client.post("/maps", **multipart(*ros_files(ros, "depot")))
    assert r.status_code == 201, r.text
    return dict(r.json())


def mask_files(ros: Path, rect: tuple[int, int, int, int], size: tuple[int, int] | None = None,
               origin: str = "[0.0, 0.0, 0]") -> dict[str, Any]:  # fmt: skip
    """A keepout filter mask for the depot as map_server files: free (254) but the rows and
    columns ``rect`` (r0, r1, c0, c1), occupied (0)."""
    h, w = size or (307, 604)
    pixels = np.full((h, w), 254, dtype=np.uint8)
    r0, r1, c0, c1 = rect
    pixels[r0:r1, c0:c1] = 0
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG")
    yaml = (
        f"image: keepout_mask.png\nmode: trinary\nresolution: 0.05\norigin: {origin}\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.25\n"
    ).encode()
    return multipart(yaml, buf.getvalue())


async def test_keepout_polygon_blocks_cells_and_keeps_the_base(
    client: httpx.AsyncClient, depot: dict[str, Any], ros: Path
) -> None:
    base_id = depot["map_id"]
    speed = [(2.0, 2.0), (6.0, 2.0), (6.0, 5.0), (2.0, 5.0)]
    body = {"keepout": [points(ZONE)], "speed": [{"polygon": points(speed), "max_speed": 0.3}]}
    r = await client.post(f"/maps/{base_id}/zones", json=body)
    assert r.status_code == 201, r.text
    zoned = r.json()
    assert zoned["map_id"] != base_id
    assert (zoned["height"], zoned["width"]) == (depot["height"], depot["width"])
    base_map = planner.read_ros_map(ros / "depot.yaml")
    keepout = polygon_cells(base_map.frame, tuple(ZONE))
    newly = int(np.count_nonzero(keepout & (base_map.occupancy < 65)))
    assert newly > 10000
    assert zoned["occupied_cells"] == depot["occupied_cells"] + newly
    assert zoned["zones"] == {
        "base_map_id": base_id,
        "keepout": [points(ZONE)],
        "speed": [{"polygon": points(speed), "max_speed": 0.3}],
        "keepout_masks": [],
    }
    # The base is unchanged, and zoning it again the same way gives the same map.
    again = await client.get(f"/maps/{base_id}")
    assert again.json() == depot
    assert again.json().get("zones") is None
    same = await client.post(f"/maps/{base_id}/zones", json=body)
    assert same.status_code == 200
    assert same.json() == zoned
    assert (await client.get(f"/maps/{zoned['map_id']}")).json() == zoned


async def test_plans_on_a_zoned_depot_never_enter_the_keepout(
    client: httpx.AsyncClient, depot: dict[str, Any], ros: Path
) -> None:
    """The done-when check: 20 seeded pairs whose unzoned route crosses the keepout zone (a
    Nav2 keepout mask drawn over part of the depot); on the zoned map no plan comes within the
    robot's radius of a keepout cell, and the same with the zone as a polygon."""
    base_id = depot["map_id"]
    base_map = planner.read_ros_map(ros / "depot.yaml")
    frame = base_map.frame
    rect = (70, 250, 260, 340)  # rows 70..250, cols 260..340: about x 13..17 m, y 2.85..11.85 m
    r = await client.post(f"/maps/{base_id}/zones", **mask_files(ros, rect))
    assert r.status_code == 201, r.text
    masked = r.json()
    assert masked["zones"]["keepout_masks"][0]["cells"] == 180 * 80
    r = await client.post(f"/maps/{base_id}/zones", json={"keepout": [points(ZONE)]})
    polygon_id = r.json()["map_id"]
    keep = np.zeros(frame.shape, dtype=bool)
    keep[rect[0] : rect[1], rect[2] : rect[3]] = True
    poly_keep = polygon_cells(frame, tuple(ZONE))

    free = planner.analyse_map(base_map, planner.resolve_params("wide", robot_radius=RADIUS))
    assert free.cspace is not None
    traversable = np.argwhere(free.cspace.traversable == 1)
    rng = np.random.default_rng(23)
    crossing = 0
    tried = 0
    while crossing < 20:
        tried += 1
        assert tried < 400, "too few pairs cross the zone"
        a, b = traversable[rng.integers(len(traversable), size=2)]
        if _near(keep | poly_keep, [a, b], RADIUS / frame.resolution + 1):
            continue  # ends that the zone itself rules out are not this check's business
        pair = {"start": a.tolist(), "goal": b.tolist(), "robot_radius": RADIUS}
        r = await client.post("/plan", json={"map_id": base_id, **pair})
        assert r.status_code == 201, r.text
        path = np.array(r.json()["preview"]["path"])
        if not (keep[path[:, 0], path[:, 1]].any() and poly_keep[path[:, 0], path[:, 1]].any()):
            continue
        crossing += 1
        for zoned_id, cells in ((masked["map_id"], keep), (polygon_id, poly_keep)):
            r = await client.post("/plan", json={"map_id": zoned_id, **pair})
            assert r.status_code == 201, r.text  # the aisles around the zone stay open
            preview = r.json()["preview"]
            path = np.array(preview["path"])
            assert not _near(cells, path, RADIUS / frame.resolution), pair
            # The poses too keep the robot's radius from every keepout cell's center.
            xy = np.array([[p["x"], p["y"]] for p in preview["poses"]])
            centers = frame.centers(_rim(cells))
            gap = np.hypot(
                xy[:, None, 0] - centers[None, :, 0], xy[:, None, 1] - centers[None, :, 1]
            )
            assert float(gap.min()) > RADIUS, pair


def _rim(cells: np.ndarray) -> np.ndarray:
    """The cells of ``cells`` with a neighbour outside it: the nearest cell of ``cells`` to any
    cell outside it is one of these."""
    padded = np.pad(cells, 1)
    inner = padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:]
    return np.argwhere(cells & ~inner)


def _near(cells: np.ndarray, path: Any, reach: float) -> bool:
    """Whether any of ``path``'s cells is within ``reach`` cells (center to center) of a cell
    of ``cells``, against every cell of its rim."""
    where = np.argwhere(cells)
    return any(float(np.min(np.hypot(where[:, 0] - r, where[:, 1] - c))) <= reach for r, c in path)


@pytest.mark.parametrize(
    ("body", "field", "words"),
    [
        ({"keepout": [[{"x": 1, "y": 1}, {"x": 2, "y": 1}]]}, "keepout[0]", "at least 3"),
        ({"keepout": [points(BOWTIE)]}, "keepout[0]", "intersects itself"),
        ({"speed": [{"polygon": points(ZONE), "max_speed": 0}]}, "speed[0].max_speed", "than 0"),
        ({"speed": [{"polygon": points(ZONE)}]}, "speed[0].max_speed", "Field required"),
        ({"keepout": [points(ZONE)], "keepuot": []}, "keepuot", "unknown field"),
        ({"keepout": [[{"x": 1, "y": 1, "z": 0}, *TWO]]}, "keepout[0][0].z", "unknown field"),
        ({"keepout": [[{"x": "1", "y": 1}, *TWO]]}, "keepout[0][0].x", "valid number"),
        ({"keepout": [[{"x": 1e300, "y": 1}, *TWO]]}, "keepout[0][0].x", "must be at most"),
        ({}, "body", "give 'keepout', 'speed', or a keepout mask"),
        ({"keepout": [points(FAR)]}, "keepout[0]", "holds no cell"),
    ],
)  # fmt: skip
async def test_bad_zones_are_422_naming_the_field(
    client: httpx.AsyncClient, depot: dict[str, Any], body: Any, field: str, words: str
) -> None:
    r = await client.post(f"/maps/{depot['map_id']}/zones", json=body)
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert words in detail, detail
    assert field in detail or field in str(r.json().get("field")), r.json()


async def test_non_finite_coordinates_are_refused(
    client: httpx.AsyncClient, depot: dict[str, Any]
) -> None:
    raw = b'{"keepout": [[{"x": NaN, "y": 1}, {"x": 2, "y": 1}, {"x": 2, "y": 2}]]}'
    r = await client.post(
        f"/maps/{depot['map_id']}/zones", content=raw, headers={"content-type": "application/json"}
    )
    assert r.status_code == 422
    raw = b'{"keepout": [[{"x": 1e999, "y": 1}, {"x": 2, "y": 1}, {"x": 2, "y": 2}]]}'
    r = await client.post(
        f"/maps/{depot['map_id']}/zones", content=raw, headers={"content-type": "application/json"}
    )
    assert r.status_code == 422


async def test_masks_of_another_size_or_frame_are_refused(
    client: httpx.AsyncClient, depot: dict[str, Any], ros: Path
) -> None:
    url = f"/maps/{depot['map_id']}/zones"
    r = await client.post(url, **mask_files(ros, (0, 10, 0, 10), size=(300, 604)))
    assert r.status_code == 422
    assert r.json()["field"] == "image"
    assert "604 x 300" in r.json()["detail"]
    r = await client.post(url, **mask_files(ros, (0, 10, 0, 10), origin="[1.0, 0.0, 0]"))
    assert r.status_code == 422
    assert r.json()["field"] == "yaml.origin"
    files = mask_files(ros, (0, 10, 0, 10))
    del files["files"]["image"]
    r = await client.post(url, **files)
    assert r.status_code == 422
    assert "'image' is missing" in r.json()["detail"]
    files = mask_files(ros, (0, 10, 0, 10))
    files["files"]["image"] = ("m.png", b"not an image", "image/png")
    r = await client.post(url, **files)
    assert r.status_code == 422


async def test_zones_on_an_unknown_map_are_404(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps/" + "0" * 64 + "/zones", json={"keepout": [points(ZONE)]})
    assert r.status_code == 404
    assert r.json()["field"] == "map_id"


async def test_zones_are_tenant_scoped() -> None:
    settings = SMALL.model_copy(update={"api_keys": SecretStr("alpha-key, beta-key")})
    app: FastAPI
    from service.main import create_app

    app = create_app(settings)
    a = {"Authorization": "Bearer alpha-key"}
    b = {"Authorization": "Bearer beta-key"}
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://s") as client:
            grid = [[0] * 8 for _ in range(8)]
            map_id = (await client.post("/maps", json={"grid": grid}, headers=a)).json()["map_id"]
            body = {"keepout": [points([(1, 1), (3, 1), (3, 3)])]}
            assert (await client.post(f"/maps/{map_id}/zones", json=body)).status_code == 401
            assert (
                await client.post(f"/maps/{map_id}/zones", json=body, headers=b)
            ).status_code == 404
            r = await client.post(f"/maps/{map_id}/zones", json=body, headers=a)
            assert r.status_code == 201
            zoned = r.json()["map_id"]
            assert (await client.get(f"/maps/{zoned}", headers=b)).status_code == 404
            assert math.isclose(r.json()["resolution"], 1.0)


async def test_a_zoned_maps_analysis_is_derived_from_its_bases(
    client: httpx.AsyncClient, depot: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    """With the base's analysis cached, the zoned map's is derived from it; the plan is the one
    a fresh upload of the zoned cells gets."""
    calls: list[Any] = []
    derive = planner.rezone_analysis

    def spy(*args: Any) -> Any:
        out = derive(*args)
        calls.append(out)
        return out

    monkeypatch.setattr(planner, "rezone_analysis", spy)
    base_id = depot["map_id"]
    ends = {"start": {"x": 3.0, "y": 7.5}, "goal": {"x": 27.0, "y": 7.5}, "robot_radius": RADIUS}
    r = await client.post(f"/maps/{base_id}/zones", json={"keepout": [points(ZONE)]})
    zoned_id = r.json()["map_id"]
    cold = await client.post("/plan", json={"map_id": zoned_id, **ends})  # no base analysis yet
    assert cold.status_code == 201
    assert calls == []
    await client.post("/plan", json={"map_id": base_id, **ends})
    r = await client.post(f"/maps/{base_id}/zones", json={"keepout": [points(ZONE[::-1])]})
    derived = await client.post("/plan", json={"map_id": r.json()["map_id"], **ends})
    assert derived.status_code == 201
    assert len(calls) == 1
    assert calls[0] is not None
    # The same cells (the polygon reversed holds the same centers): the same plan.
    for key in ("path", "poses", "min_clearance_m", "mean_clearance_m", "arc_cost"):
        assert derived.json()["preview"][key] == cold.json()["preview"][key], key


async def test_speed_zones_cap_the_poses_and_give_the_duration(client: httpx.AsyncClient) -> None:
    """A 4 m corridor at 0.1 m a cell, a speed zone over its middle metre: the poses inside
    carry its max_speed (and only they), the preview's duration drives the poses at the
    nominal speed capped there, and the step's poses carry it too."""
    grid = [[0] * 40 for _ in range(10)]
    r = await client.post("/maps", json={"grid": grid, "resolution": 0.1})
    base_id = r.json()["map_id"]
    slow = [(1.5, -1.0), (2.5, -1.0), (2.5, 2.0), (1.5, 2.0)]
    r = await client.post(
        f"/maps/{base_id}/zones", json={"speed": [{"polygon": points(slow), "max_speed": 0.2}]}
    )
    assert r.status_code == 201, r.text
    zoned = r.json()
    assert zoned["occupied_cells"] == 0  # a speed zone blocks nothing
    ends = {"start": {"x": 0.25, "y": 0.45}, "goal": {"x": 3.75, "y": 0.55}}
    for nominal in (None, 0.8):
        params = {} if nominal is None else {"nominal_speed": nominal}
        r = await client.post("/plan", json={"map_id": zoned["map_id"], **ends, "params": params})
        assert r.status_code == 201, r.text
        plan = r.json()
        assert plan["params"]["nominal_speed"] == (nominal or 0.5)
        poses = plan["preview"]["poses"]
        inside = [1.5 < p["x"] < 2.5 for p in poses]
        assert any(inside)
        assert not all(inside)
        for pose, held in zip(poses, inside, strict=True):
            assert pose.get("max_speed") == (0.2 if held else None), pose
        expected = 0.0
        speed = nominal or 0.5
        for a, b in itertools.pairwise(poses):
            cap = min(speed, a.get("max_speed", math.inf), b.get("max_speed", math.inf))
            expected += math.hypot(b["x"] - a["x"], b["y"] - a["y"]) / cap
        assert plan["preview"]["duration_s"] == pytest.approx(expected, rel=1e-5)
        assert plan["preview"]["duration_s"] > plan["preview"]["length_poses_m"] / speed
    # The unzoned map: no pose carries a cap; the duration is the length at the nominal speed.
    r = await client.post("/plan", json={"map_id": base_id, **ends})
    plan = r.json()
    assert all(set(p) == {"x", "y", "yaw"} for p in plan["preview"]["poses"])
    assert plan["preview"]["duration_s"] == pytest.approx(
        plan["preview"]["length_poses_m"] / 0.5, rel=1e-5
    )
    # A step's poses carry the cap too, within the zone.
    r = await client.post("/plan", json={"map_id": zoned["map_id"], **ends})
    plan_id = r.json()["plan_id"]
    caps = []
    for _ in range(40):
        r = await client.post(f"/plan/{plan_id}/step", json={})
        assert r.status_code == 200, r.text
        caps += [p.get("max_speed") for p in r.json()["poses"]]
        if r.json()["status"] == "reached":
            break
    assert 0.2 in caps
    assert None in caps


@pytest.mark.parametrize("value", [0, -1, "fast", True, 1e9])
async def test_nominal_speed_is_checked(client: httpx.AsyncClient, value: Any) -> None:
    r = await client.post("/maps", json={"grid": [[0, 0], [0, 0]]})
    body = {"map_id": r.json()["map_id"], "start": [0, 0], "goal": [1, 1]}
    r = await client.post("/plan", json={**body, "params": {"nominal_speed": value}})
    assert r.status_code == 422
    assert r.json()["field"] == "params.nominal_speed"


async def test_pictures_of_a_zoned_map_draw_its_zones(
    client: httpx.AsyncClient, depot: dict[str, Any]
) -> None:
    base_id = depot["map_id"]
    body = {"keepout": [points(ZONE)], "speed": [{"polygon": points(SLOW), "max_speed": 0.3}]}
    zoned_id = (await client.post(f"/maps/{base_id}/zones", json=body)).json()["map_id"]
    pictures = []
    for map_id in (base_id, zoned_id):
        r = await client.get(f"/maps/{map_id}/render.png", params={"cell": 2})
        assert r.status_code == 200
        pictures.append(np.asarray(Image.open(io.BytesIO(r.content)).convert("RGB")))
    plain, zoned = pictures
    # The middle of the keepout zone (x 15 m, y 7.5 m): red hatching on pale red.
    y, x = int((307 - 7.5 / 0.05) * 2), int(15 / 0.05 * 2)
    colours = {tuple(int(v) for v in p) for p in zoned[y - 6 : y + 6, x - 6 : x + 6].reshape(-1, 3)}
    assert colours == {(200, 0, 0), (255, 205, 205)}
    assert (plain[y - 6 : y + 6, x - 6 : x + 6] == 255).all()


async def test_a_mask_and_polygons_in_one_multipart_request(
    client: httpx.AsyncClient, depot: dict[str, Any], ros: Path
) -> None:
    import json

    files = mask_files(ros, (10, 20, 10, 30))
    files["data"] = {
        "speed": json.dumps([{"polygon": points(ZONE), "max_speed": 0.4}]),
        "keepout": json.dumps([points([(25.0, 2.0), (26.0, 2.0), (26.0, 3.0)])]),
    }
    r = await client.post(f"/maps/{depot['map_id']}/zones", **files)
    assert r.status_code == 201, r.text
    zones = r.json()["zones"]
    assert zones["keepout_masks"][0]["cells"] == 200
    assert zones["speed"][0]["max_speed"] == 0.4
    assert len(zones["keepout"]) == 1
    files["data"] = {"speed": "fast"}
    r = await client.post(f"/maps/{depot['map_id']}/zones", **files)
    assert r.status_code == 422


async def test_a_polygon_of_many_points_is_not_refused_by_the_key_limit() -> None:
    """A zones body has its own key limit (two keys a point): a 900-point polygon passes even
    where steps may give only 100 circles (whose limit, 3 x 100 + 1024 keys, it would pass)."""
    from service.main import create_app

    app = create_app(SMALL.model_copy(update={"max_dynamic_obstacles": 100}))
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://s") as client:
            grid = [[0] * 40 for _ in range(40)]
            map_id = (await client.post("/maps", json={"grid": grid})).json()["map_id"]
            circle = [
                (20 + 10 * math.cos(t), 20 + 10 * math.sin(t))
                for t in np.linspace(0, 2 * math.pi, 900, endpoint=False)
            ]
            r = await client.post(f"/maps/{map_id}/zones", json={"keepout": [points(circle)]})
            assert r.status_code == 201, r.text
            flood = {"keepout": [points(circle)], **{f"k{i}": 1 for i in range(2 * 256 * 1000)}}
            r = await client.post(f"/maps/{map_id}/zones", json=flood)
            assert r.status_code in (413, 422), r.text


async def test_a_keepout_mask_may_be_as_large_as_a_map_upload(ros: Path) -> None:
    """A mask is a map: its body is held to PLANNER_MAX_BODY_BYTES, not to the smaller limit
    of a step's (set here to 1 KiB, under the mask's size)."""
    from service.main import create_app

    app = create_app(BIG.model_copy(update={"max_step_body_bytes": 1024}))
    async with running(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://s") as client:
            r = await client.post("/maps", **multipart(*ros_files(ros, "depot")))
            assert r.status_code == 201, r.text
            pixels = np.full((307, 604), 254, dtype=np.uint8)
            rng = np.random.default_rng(0)
            pixels[100:180, 200:280] = np.where(rng.random((80, 80)) < 0.5, 0, 254)
            buf = io.BytesIO()
            Image.fromarray(pixels).save(buf, format="PNG")
            yaml = b"image: m.png\nresolution: 0.05\norigin: [0.0, 0.0, 0]\n"
            files = multipart(yaml, buf.getvalue())
            assert len(buf.getvalue()) > 1024
            r = await client.post(f"/maps/{r.json()['map_id']}/zones", **files)
            assert r.status_code == 201, r.text
            r = await client.post("/plan", json={"map_id": "x" * 2000, "start": [0, 0]})
            assert r.status_code == 413, r.text

"""``GET /maps/{map_id}/render.png`` and ``GET /plan/{plan_id}/render.png``."""

from __future__ import annotations

import io
from pathlib import Path

import httpx
import pytest
from PIL import Image

import planner
from planner.render_axes import known_window
from planner.render_legend import COLOURS
from service.config import Settings
from tests.service.test_robot_maps import traversable_pairs

pytestmark = pytest.mark.anyio


@pytest.fixture
def settings() -> Settings:
    return Settings(pool_size=2)  # the default limits: a ROS map as JSON


# A one-cell corridor in row 2 (sealed by `wide`), and an obstacle block.
ROWS = [
    "..........",
    "..........",
    "@@@@.@@@@@",
    "..........",
    "....@@....",
    "..........",
]


def picture(response: httpx.Response) -> Image.Image:
    assert response.status_code == 200, response.text
    assert response.headers["content-type"] == "image/png"
    image = Image.open(io.BytesIO(response.content))
    assert image.format == "PNG"
    return image.convert("RGB")


def at(image: Image.Image, r: int, c: int, cell: int) -> tuple[int, int, int]:
    """The colour at the middle of cell (r, c), away from grid lines and discs' edges."""
    pixel = image.getpixel((c * cell + cell // 2, r * cell + 1 + cell // 4))
    assert isinstance(pixel, tuple)
    return (int(pixel[0]), int(pixel[1]), int(pixel[2]))


async def test_map_picture_shows_the_analysis(client: httpx.AsyncClient) -> None:
    map_id = (await client.post("/maps", json={"rows": ROWS})).json()["map_id"]
    image = picture(await client.get(f"/maps/{map_id}/render.png", params={"cell": 8}))
    width, height = image.size
    assert width >= 10 * 8
    assert height > 6 * 8  # the map, and the legend below it
    assert at(image, 2, 0, 8) == COLOURS["obstacle"]
    assert at(image, 2, 4, 8) == COLOURS["tunnel"]  # the sealed corridor cell
    assert at(image, 0, 0, 8) == COLOURS["free"]
    # The shortest preset does not seal: the corridor cell is drawn free.
    plain = picture(
        await client.get(f"/maps/{map_id}/render.png", params={"cell": 8, "preset": "shortest"})
    )
    assert at(plain, 2, 4, 8) == COLOURS["free"]
    # Default size: the planner's legible default, 24 pixels a cell on a map this small.
    assert picture(await client.get(f"/maps/{map_id}/render.png")).size[0] >= 10 * 24


async def test_plan_picture_shows_the_trajectory_and_preview(client: httpx.AsyncClient) -> None:
    body = {"rows": ROWS, "start": [0, 0], "goal": [5, 9], "preset": "shortest"}
    plan = (await client.post("/maps", json=body)).json()["plan"]
    step = await client.post(f"/plan/{plan['plan_id']}/step", json={"dynamic_obstacles": []})
    first = step.json()["position"]
    image = picture(await client.get(f"/plan/{plan['plan_id']}/render.png", params={"cell": 12}))
    assert image.size[0] >= 120
    assert image.size[1] > 72
    ahead = plan["preview"]["path"][-3]  # on the preview, not yet travelled
    assert at(image, ahead[0], ahead[1], 12) == COLOURS["preview"]
    assert at(image, first[0], first[1], 12) != COLOURS["free"]  # the robot's cell is marked
    tinted = picture(
        await client.get(f"/plan/{plan['plan_id']}/render.png", params={"cell": 12, "field": "kw"})
    )
    assert at(tinted, 0, 9, 12) != at(image, 0, 9, 12)  # free cells tinted by kw


@pytest.mark.parametrize(
    ("path", "params", "status", "field"),
    [
        ("/maps/{map_id}/render.png", {"cell": 0}, 422, "cell"),
        ("/maps/{map_id}/render.png", {"cell": 65}, 422, "cell"),
        ("/maps/{map_id}/render.png", {"field": "kw"}, 422, "field"),
        ("/maps/{map_id}/render.png", {"preset": "fast"}, 422, "preset"),
        ("/maps/{unknown}/render.png", {}, 404, "map_id"),
        ("/plan/{unknown}/render.png", {}, 404, "plan_id"),
        ("/plan/{plan_id}/render.png", {"field": "heat"}, 422, "field"),
    ],
)
async def test_bad_picture_requests_are_named(
    client: httpx.AsyncClient, path: str, params: dict[str, str | int], status: int, field: str
) -> None:
    body = {"rows": ROWS, "start": [0, 0], "goal": [5, 9]}
    created = (await client.post("/maps", json=body)).json()
    url = path.format(map_id=created["map_id"], plan_id=created["plan"]["plan_id"], unknown="0" * 8)
    r = await client.get(url, params=params)
    assert r.status_code == status
    assert r.json()["field"] == field
    assert field in r.json()["detail"]


async def test_a_picture_too_wide_is_refused(client: httpx.AsyncClient) -> None:
    map_id = (await client.post("/maps", json={"grid": [[0] * 200] * 20})).json()["map_id"]
    r = await client.get(f"/maps/{map_id}/render.png", params={"cell": 50})
    assert r.status_code == 422
    assert "10000 pixels wide; the limit is 8192 (use cell <= 40)" in r.json()["detail"]


async def test_pictures_are_documented_as_png(client: httpx.AsyncClient) -> None:
    spec = (await client.get("/openapi.json")).json()
    for path in ("/maps/{map_id}/render.png", "/plan/{plan_id}/render.png"):
        operation = spec["paths"][path]["get"]
        assert "image/png" in operation["responses"]["200"]["content"]
        assert operation["summary"]


async def test_a_ros_maps_pictures_hold_its_known_part_unless_crop_is_false(
    client: httpx.AsyncClient, ros: Path
) -> None:
    """On a real scan (mostly grey unknown space) the map's and a plan's pictures are cropped
    to the known part with axes in meters, as ``planner render`` draws them; ``crop=false``
    (the viewers' background) draws the whole map, cell (0, 0) at the top left."""
    m = planner.read_ros_map(ros / "tb3_sandbox.yaml")
    r = await client.post("/maps", json={"occupancy_grid": m.to_occupancy_grid()})
    assert r.status_code in (200, 201), r.text
    map_id = r.json()["map_id"]
    analysis = planner.analyse_map(m, planner.resolve_params("wide"))
    query = {"cell": 2}
    cropped = await client.get(f"/maps/{map_id}/render.png", params=query)
    whole = await client.get(f"/maps/{map_id}/render.png", params={**query, "crop": "false"})
    assert cropped.content == planner.render_map(analysis, cell=2, crop=True)
    assert whole.content == planner.render_map(analysis, cell=2)
    (r0, r1, c0, c1), (H, W) = known_window(analysis), m.shape
    assert (r1 - r0) * (c1 - c0) < 0.8 * H * W  # the scan's unknown margins are cut
    assert picture(cropped).size[0] < picture(whole).size[0]
    start, goal = traversable_pairs(m, 1, seed=1)[0]
    body = {"map_id": map_id, "start": start, "goal": goal}
    plan_id = (await client.post("/plan", json=body)).json()["plan_id"]
    plan = planner.plan(m, start, goal)
    drawn = await client.get(f"/plan/{plan_id}/render.png", params=query)
    assert drawn.content == planner.render_plan(plan, trajectory=[plan.start], cell=2, crop=True)
    assert picture(drawn).size[0] == picture(cropped).size[0]  # the legends differ
    assert (await client.get(f"/plan/{plan_id}/render.png?crop=nope")).status_code == 422

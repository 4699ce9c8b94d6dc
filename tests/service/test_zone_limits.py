"""Limits per map, not per request: zoning a zoned map again and again stops at the zones a map
may carry (``422`` naming the first field beyond), and the memory store keeps each map's size
with it (a new map never sums the sizes of the maps already stored)."""

from __future__ import annotations

from typing import Any

import httpx
import pytest

import planner
from planner.maps.zones import MAX_ZONES
from service.stores import memory
from service.stores.memory import MAP_OVERHEAD_BYTES, MemoryStore
from service.tenants import TENANT

pytestmark = pytest.mark.anyio


def squares(count: int, *, row: float = 0.0) -> list[dict[str, Any]]:
    """``count`` speed zones, squares 0.5 m a side along a row."""
    return [
        {
            "polygon": [
                {"x": x, "y": y}
                for x, y in ((i, row), (i + 0.5, row), (i + 0.5, row + 0.5), (i, row + 0.5))
            ],
            "max_speed": 0.3,
        }
        for i in range(count)
    ]


async def test_zoning_again_and_again_stops_at_the_maps_limit(client: httpx.AsyncClient) -> None:
    r = await client.post("/maps", json={"rows": ["." * 40] * 40})
    map_id = r.json()["map_id"]
    r = await client.post(f"/maps/{map_id}/zones", json={"speed": squares(200)})
    assert r.status_code == 201, r.text
    zoned = r.json()["map_id"]
    more = squares(100, row=2.0)
    r = await client.post(f"/maps/{zoned}/zones", json={"speed": more})
    assert r.status_code == 422, r.text
    error = r.json()
    assert (error["code"], error["field"]) == ("INVALID_INPUT", "speed[56]")
    assert f"at most {MAX_ZONES} zones" in error["detail"]
    assert "it has 200 and the request adds 100" in error["detail"]
    r = await client.post(f"/maps/{zoned}/zones", json={"speed": more[:56]})
    assert r.status_code == 201, r.text
    full = r.json()["map_id"]
    assert len(r.json()["zones"]["speed"]) == MAX_ZONES
    keepout = [[{"x": 10, "y": 10}, {"x": 20, "y": 10}, {"x": 20, "y": 20}]]
    r = await client.post(f"/maps/{full}/zones", json={"keepout": keepout})
    assert (r.status_code, r.json()["field"]) == (422, "keepout[0]")


def test_a_keepout_mask_counts_as_a_zone() -> None:
    base = planner.grid_map([[0] * 8] * 8)
    speed = [{"polygon": [(0, 0), (1, 0), (1, 1)], "max_speed": 1.0}] * MAX_ZONES
    full = planner.zone_map(base, speed=speed)
    mask = planner.zone_map(base, mask=base.occupancy == 0)
    assert mask.zones is not None
    assert mask.zones.count == 1
    with pytest.raises(planner.InvalidInput, match="adds 1: image is beyond") as info:
        planner.zone_map(full, mask=base.occupancy == 0)
    assert info.value.field == "image"


async def test_the_memory_store_sizes_a_map_once_and_never_sums_the_others(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Storing a map sizes it once (its zones by their points, not their ``repr``) and makes
    room from sums kept as maps come and go: it read every idle map of every tenant, on the
    event loop, at every put."""
    store = MemoryStore(ttl_seconds=60, max_map_bytes=1 << 30, shares=4)
    base = planner.grid_map([[0] * 10] * 10)
    zoned = planner.zone_map(base, speed=[{"polygon": [(0, 0), (5, 0), (5, 5)], "max_speed": 1}])
    for i in range(300):
        TENANT.set(f"t{i % 3}")
        assert await store.put_map(f"m{i}", zoned if i % 2 else base)
    sized: list[planner.RobotMap] = []
    size = memory._size

    def counting(robot_map: planner.RobotMap) -> int:
        sized.append(robot_map)
        return size(robot_map)

    monkeypatch.setattr(memory, "_size", counting)
    monkeypatch.setattr(planner.Zones, "__repr__", lambda z: pytest.fail("repr of zones"))
    TENANT.set("t3")
    assert await store.put_map("new", zoned)
    TENANT.set("")
    assert sized == [zoned]
    assert zoned.zones is not None
    each = 100 + MAP_OVERHEAD_BYTES
    assert store.map_bytes == 301 * each + 151 * zoned.zones.nbytes


def test_a_mask_off_the_maps_frame_is_refused_before_it_is_decoded(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Its size (from the image's header), its YAML's resolution and origin are checked first:
    a 16 M pixel mask of the wrong resolution is refused without decoding a pixel."""
    import planner
    from service.resources import zones

    decoded: list[int] = []
    decode = planner.decode_map_image

    def counted(*args: Any, **kwargs: Any) -> Any:
        decoded.append(1)
        return decode(*args, **kwargs)

    monkeypatch.setattr(planner, "decode_map_image", counted)
    frame = planner.MapFrame((4, 6), 0.05, (0.0, 0.0, 0.0))
    image = b"P5\n6 4\n255\n" + bytes(24)
    wider = b"P5\n7 4\n255\n" + bytes(28)
    same = b"image: m.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"
    for yaml, picture, field in (
        (b"image: m.pgm\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\n", image, "yaml.resolution"),
        (b"image: m.pgm\nresolution: 0.05\norigin: [1.0, 0.0, 0.0]\n", image, "yaml.origin"),
        (same, wider, "image"),
    ):
        with pytest.raises(planner.InvalidInput) as error:
            zones._mask(frame, yaml, picture)
        assert error.value.field == field
    assert decoded == []
    zones._mask(frame, same, image)
    assert decoded == [1]

"""Zoning a map against uploading the zoned map afresh, side by side in one run.

Over HTTP (the app in this process, through httpx's ASGI transport: the routes, validation, the
store and the pool, no sockets), on the shared ``depot`` ROS map and on a 2 x 3 tiling of it
(1812 x 614 cells), with a robot radius of 0.22 m, the zone over the (first) hall:

- ``zoning``: ``POST /maps/{id}/zones`` with a keepout polygon (the base map's cells are read
  from the store, not sent); and the same with a Nav2 keepout mask (multipart ``yaml`` +
  ``image``);
- ``zoning + plan``: that, then the first plan on the zoned map (its analysis derived from the
  base's cached one, then the wave and the path);
- ``upload + plan``: ``POST /maps`` of the zoned map's own image (multipart), then the first plan
  on it (the analysis computed afresh, the wave, the path).

Each iteration zones a polygon shifted by a hair, and uploads an image with one pixel changed,
so that every map and analysis is new; the contenders alternate. Then in the planner alone:
:func:`planner.rezone_analysis` against :func:`planner.analyse_map` of the zoned map, on
``depot`` and on a 2 x 3 tiling of it (1208 x 921 cells), for a zone among the racks and one in
the open hall, with the window the distance transform was redone in. Prints markdown::

    .venv/bin/python benchmarks/zones.py            # 15 alternated iterations
    .venv/bin/python benchmarks/zones.py --repeat 30
"""

from __future__ import annotations

import argparse
import asyncio
import io
import platform
import statistics
import subprocess
import sys
import time
from typing import Any

import httpx
import numpy as np
from common import ROOT, ros_maps
from PIL import Image

sys.path.insert(0, str(ROOT))

import planner
from service.config import Settings
from service.main import create_app

RADIUS = 0.22
RACKS = [(29.0, 7.0), (31.0, 7.0), (31.0, 9.0), (29.0, 9.0)]  # among the racks, 2 m square
HALL = [(13.0, 3.0), (17.0, 3.0), (17.0, 12.0), (13.0, 12.0)]  # the open hall, 4 x 9 m
START, GOAL = {"x": 3.0, "y": 7.5}, {"x": 27.0, "y": 7.5}


def cpu() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return platform.processor() or "unknown CPU"
    fields = dict(line.split(":", 1) for line in out.splitlines() if ":" in line)
    return f"{fields.get('Model name', '?').strip()}, {fields.get('CPU(s)', '?').strip()} CPUs"


def png(occupancy: np.ndarray) -> bytes:
    """A map_server image of an occupancy grid (trinary: 0 occupied, 254 free, 205 unknown)."""
    pixels = np.where(occupancy >= 65, 0, np.where(occupancy < 0, 205, 254)).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG")
    return buf.getvalue()


YAML = (
    b"image: m.png\nmode: trinary\nresolution: 0.05\norigin: [0.0, 0.0, 0]\nnegate: 0\n"
    b"occupied_thresh: 0.65\nfree_thresh: 0.25\n"
)


def files(yaml: bytes, image: bytes) -> dict[str, Any]:
    return {
        "yaml": ("m.yaml", yaml, "application/yaml"),
        "image": ("m.png", image, "application/octet-stream"),
    }


def points(polygon: Any, shift: float = 0.0) -> list[dict[str, float]]:
    return [{"x": x + shift, "y": y} for x, y in polygon]


async def http(name: str, base: planner.RobotMap, repeat: int) -> dict[str, Any]:
    """The four contenders over HTTP on ``base``, alternated ``repeat`` times (after one round
    that warms up): their times in ms."""
    mask = np.zeros(base.shape, dtype=np.int8)
    mask[70:250, 260:340] = 100
    zoned_cells = planner.zone_map(base, keepout=[HALL]).occupancy
    times: dict[str, list[float]] = {
        k: [] for k in ("zoning", "zoning (mask)", "zoning + plan", "upload + plan")
    }
    app = create_app(Settings(pool_size=2))
    async with app.router.lifespan_context(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://bench") as client:
            r = await client.post("/maps", files=files(YAML, png(base.occupancy)))
            base_id = r.json()["map_id"]
            plan = {"start": START, "goal": GOAL, "robot_radius": RADIUS}
            r = await client.post("/plan", json={"map_id": base_id, **plan})  # caches the base's
            assert r.status_code == 201, r.text
            for i in range(repeat + 1):  # the first round warms up, not counted
                keep = i > 0
                shift = 1e-6 * (i + 1)

                t0 = time.perf_counter()
                r = await client.post(
                    f"/maps/{base_id}/zones", json={"keepout": [points(HALL, shift)]}
                )
                t1 = time.perf_counter()
                assert r.status_code == 201, r.text
                if keep:
                    times["zoning"].append((t1 - t0) * 1e3)

                t0 = time.perf_counter()
                body = {"keepout": [points(HALL, shift + 5e-7)]}
                r = await client.post(f"/maps/{base_id}/zones", json=body)
                zoned_id = r.json()["map_id"]
                r2 = await client.post("/plan", json={"map_id": zoned_id, **plan})
                t1 = time.perf_counter()
                assert r2.status_code == 201, r2.text
                assert not r2.json()["analysis"]["cache_hit"]
                if keep:
                    times["zoning + plan"].append((t1 - t0) * 1e3)

                cells = zoned_cells.copy()
                cells[0, i % cells.shape[1]] = 0 if cells[0, i % cells.shape[1]] else 100
                fresh_png = png(cells)
                t0 = time.perf_counter()
                r = await client.post("/maps", files=files(YAML, fresh_png))
                fresh_id = r.json()["map_id"]
                r2 = await client.post("/plan", json={"map_id": fresh_id, **plan})
                t1 = time.perf_counter()
                assert r.status_code == 201, r.text
                assert r2.status_code == 201, r2.text
                if keep:
                    times["upload + plan"].append((t1 - t0) * 1e3)

                m = mask.copy()
                m[0, i % m.shape[1]] = 100
                m_png = png(m)
                t0 = time.perf_counter()
                r = await client.post(f"/maps/{base_id}/zones", files=files(YAML, m_png))
                t1 = time.perf_counter()
                assert r.status_code == 201, r.text
                if keep:
                    times["zoning (mask)"].append((t1 - t0) * 1e3)
    H, W = base.shape
    return {"map": name, "size": f"{W} x {H}", "times": times}


def tiled(robot_map: planner.RobotMap, rows: int, cols: int) -> planner.RobotMap:
    occ = np.tile(robot_map.occupancy, (rows, cols))
    return planner.RobotMap(np.ascontiguousarray(occ), planner.MapFrame(occ.shape, 0.05))


def analyses(repeat: int) -> list[dict[str, Any]]:
    rows = []
    params = planner.resolve_params("wide", robot_radius=RADIUS)
    for name, robot_map in maps():
        base = planner.analyse_map(robot_map, params)
        for where, zone in (("racks", RACKS), ("hall", HALL)):
            t0 = time.perf_counter()
            zoned = planner.zone_map(robot_map, keepout=[zone])
            zone_ms = (time.perf_counter() - t0) * 1e3
            fresh, derived = [], []
            window = None
            for _ in range(repeat):
                t0 = time.perf_counter()
                planner.analyse_map(zoned, params)
                t1 = time.perf_counter()
                out = planner.rezone_analysis(base, zoned, params)
                t2 = time.perf_counter()
                assert out is not None
                window = out[1]
                fresh.append((t1 - t0) * 1e3)
                derived.append((t2 - t1) * 1e3)
            assert window is not None
            H, W = robot_map.shape
            rows.append(
                {
                    "map": name,
                    "size": f"{W} x {H}",
                    "zone": where,
                    "zone_ms": zone_ms,
                    "fresh": statistics.median(fresh),
                    "derived": statistics.median(derived),
                    "fresh_min": min(fresh),
                    "derived_min": min(derived),
                    "window": window.cells / (H * W),
                }
            )
    return rows


def maps() -> list[tuple[str, planner.RobotMap]]:
    depot = planner.read_ros_map(ros_maps() / "depot.yaml")
    return [("depot", depot), ("depot tiled 2 x 3", tiled(depot, 2, 3))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args()
    print(f"CPU: {cpu()}, Python {platform.python_version()}; {args.repeat} iterations\n")
    kinds = ("zoning", "zoning (mask)", "zoning + plan", "upload + plan")
    print("| over HTTP, radius 0.22 m | size | " + " | ".join(kinds) + " |")
    print("|---|---|" + "---:|" * len(kinds))
    for name, robot_map in maps():
        run = asyncio.run(http(name, robot_map, args.repeat))
        med = {k: statistics.median(v) for k, v in run["times"].items()}
        p90 = {k: float(np.percentile(v, 90)) for k, v in run["times"].items()}
        base = med["upload + plan"]
        cells = [f"{med[k]:.1f} ms (p90 {p90[k]:.1f}), **{med[k] / base:.2f}**" for k in kinds]
        print(f"| {name} | {run['size']} | " + " | ".join(cells) + " |")
    print()
    print(
        "| map | size | zone | zone_map ms | analysis afresh ms (min) | derived ms (min) "
        "| derived / afresh, medians (mins) | EDT window (share of the map) |"
    )
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for row in analyses(3 * args.repeat):
        print(
            f"| {row['map']} | {row['size']} | {row['zone']} | {row['zone_ms']:.1f} | "
            f"{row['fresh']:.1f} ({row['fresh_min']:.1f}) | "
            f"{row['derived']:.1f} ({row['derived_min']:.1f}) | "
            f"**{row['derived'] / row['fresh']:.2f}** "
            f"({row['derived_min'] / row['fresh_min']:.2f}) | {row['window']:.0%} |"
        )


if __name__ == "__main__":
    main()

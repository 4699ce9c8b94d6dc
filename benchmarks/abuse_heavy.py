"""Heavy work as an attacker asks for it (issue 36): zoning a zoned map again and again, many
waypoints, passages and goal tolerances on the largest maps, masks and keepouts over them, and
a flood of big analyses; the runner has the other tenant's small requests go on meanwhile.

A pattern with a setup (uploading its big map, not what is measured) takes the setup's answer
(a map id); each returns what the attacker got."""

from __future__ import annotations

import threading
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import orjson
from abuse_service import Service

JSON = {"content-type": "application/json"}
RESOLUTION = 0.05
HUGE = 4096
"""The largest map's side (``PLANNER_MAX_MAP_CELLS``, 4096 x 4096 by default)."""


def rows_of(blocked: np.ndarray) -> list[str]:
    """Moving AI rows of a boolean grid (``@`` blocked), without a Python loop per cell."""
    chars = np.where(blocked, ord("@"), ord(".")).astype(np.uint8)
    return [bytes(row).decode() for row in chars]


def _upload(service: Service, blocked: np.ndarray) -> str:
    """The attacker's map of ``blocked`` cells at 0.05 m, uploaded as rows: its id."""
    body = orjson.dumps({"rows": rows_of(blocked), "resolution": RESOLUTION})
    with service.client() as c:
        r = c.post("/maps", content=body, headers=JSON)
    assert r.status_code in (200, 201), r.text[:300]
    return str(r.json()["map_id"])


def free_map(side: int) -> Callable[[Service], str]:
    def setup(service: Service) -> str:
        return _upload(service, np.zeros((side, side), dtype=bool))

    return setup


def rooms(side: int) -> np.ndarray:
    """The blocked cells of rooms 128 cells (6.4 m) a side, walls 4 cells thick, a door of 14
    cells (0.7 m) in each wall of each room: a passage for a robot of 0.2 m at every door."""
    blocked = np.zeros((side, side), dtype=bool)
    for k in range(0, side, 128):
        blocked[k : k + 4, :] = True
        blocked[:, k : k + 4] = True
    for k in range(64, side, 128):
        blocked[k : k + 14, :] = False
        blocked[:, k : k + 14] = False
    return blocked


def rooms_map(side: int) -> Callable[[Service], str]:
    """:func:`rooms`, uploaded."""

    def setup(service: Service) -> str:
        return _upload(service, rooms(side))

    return setup


def walled_map(service: Service) -> str:
    """A free 4096 x 4096 map with a 3000 x 3000 block in its middle."""
    blocked = np.zeros((HUGE, HUGE), dtype=bool)
    edge = (HUGE - 3000) // 2
    blocked[edge : edge + 3000, edge : edge + 3000] = True
    return _upload(service, blocked)


def _across(service: Service, map_id: str) -> httpx.Response:
    """A plan from corner to corner of a 4096 x 4096 map (the default preset)."""
    with service.client() as c:
        return c.post("/plan", json={"map_id": map_id, "start": [0, 0], "goal": [HUGE - 1] * 2})


def walled_analysed(service: Service) -> str:
    """:func:`walled_map`, analysed (a plan across it): what a tolerance search starts from."""
    map_id = walled_map(service)
    r = _across(service, map_id)
    assert r.status_code == 201, r.text[:300]
    return map_id


def first_plan(service: Service, map_id: str) -> str:
    """A plan across a 4096 x 4096 map not planned on before: its analysis (the configuration
    space, the wall term, the clearance) and a wave over most of it."""
    r = _across(service, map_id)
    if r.status_code != 201:
        return f"{r.status_code} {r.json().get('code', '')}".strip()
    return f"201, analysis {r.json()['analysis']['analysis_ms'] / 1e3:.1f} s"


def _ring(cx: float, cy: float, radius: float, n: int) -> list[dict[str, float]]:
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return [{"x": cx + radius * np.cos(a), "y": cy + radius * np.sin(a)} for a in angles]


def rezone(service: Service) -> str:
    """Zoning the last zoned map again, 20 times, each with 256 speed zones of 39 points (a
    request's limits): issue 36 saw the map's zones grow without bound (5,120 at the 20th), each
    put sum the zones of every map, ``GET /maps/{id}`` grow to 18 MB and a step cost 117 ms.
    The answer: the zonings' statuses, then ``GET /maps/{id}``'s size and time and a step's
    median time on the last map zoned."""
    statuses: Counter[int] = Counter()
    with service.client() as c:
        body = {"rows": ["." * 200] * 200, "resolution": RESOLUTION}
        map_id = c.post("/maps", json=body).json()["map_id"]
        for k in range(20):
            centers = [
                (0.3 + 0.6 * i + 0.01 * k, 0.3 + 0.6 * j) for i in range(16) for j in range(16)
            ]
            speed = [{"polygon": _ring(x, y, 0.2, 39), "max_speed": 0.3} for x, y in centers]
            r = c.post(f"/maps/{map_id}/zones", json={"speed": speed})
            statuses[r.status_code] += 1
            if r.status_code in (200, 201):
                map_id = r.json()["map_id"]
        t0 = time.monotonic()
        size = len(c.get(f"/maps/{map_id}").content)
        got = time.monotonic() - t0
        plan = c.post("/plan", json={"map_id": map_id, "start": [100, 0], "goal": [100, 199]})
        plan_id = plan.json()["plan_id"]
        times = []
        for _ in range(20):
            t0 = time.monotonic()
            c.post(f"/plan/{plan_id}/step", json={})
            times.append(time.monotonic() - t0)
    zonings = ", ".join(f"{n} x {code}" for code, n in sorted(statuses.items()))
    step = 1e3 * float(np.median(times))
    return f"{zonings}; GET {size / 1e6:.2f} MB in {got:.3f} s; step {step:.1f} ms"


def waypoints(service: Service) -> str:
    """A free 1024 x 1024 map at 0.05 m, a patrol of 8 waypoints between two cells, then 64
    waypoints spread over it (twice): issue 36 saw a 500 (a route's plan forgotten twice)."""
    with service.client() as c:
        body = {"rows": ["." * 1024] * 1024, "resolution": RESOLUTION}
        map_id = c.post("/maps", json=body).json()["map_id"]
        ends = {"map_id": map_id, "start": [0, 0], "goal": [1023, 1023]}
        spread = np.random.default_rng(36).integers(0, 1024, (64, 2)).tolist()
        answers = []
        for points in ([[900, 100], [100, 900]] * 4, spread, spread):
            try:
                r = c.post("/plan", json={**ends, "waypoints": points})
                answers.append(str(r.status_code))
            except httpx.HTTPError as exc:  # a connection the server dropped
                answers.append(type(exc).__name__)
    return " ".join(answers)


def passages(service: Service, map_id: str) -> str:
    """Three clients at once, each asking the map's passages for a robot of 0.2 m with its own
    ``max_width`` (0.8, 1.0, 1.2 m: three analyses, none cached): their statuses and how many
    passages each found."""

    def ask(width: float) -> str:
        with service.client() as c:
            params = {"robot_radius": 0.2, "max_width": width}
            r = c.get(f"/maps/{map_id}/passages", params=params)
        found = f" ({len(r.json()['passages'])})" if r.status_code == 200 else ""
        return f"{r.status_code}{found}"

    with ThreadPoolExecutor(3) as clients:
        return " ".join(clients.map(ask, (0.8, 1.0, 1.2)))


def tolerance(service: Service, map_id: str) -> str:
    """A plan whose goal is the middle of the 3000 x 3000 block, ``goal_tolerance`` 100 m
    (2,000 cells), on the analysed map: issue 36 saw 29.7 s and +2.15 GB. Its status, and how
    far the goal moved."""
    body = {"map_id": map_id, "start": [0, 0], "goal": [HUGE // 2, HUGE // 2]}
    with service.client() as c:
        r = c.post("/plan", json={**body, "goal_tolerance": 100.0})
    if r.status_code != 201:
        return f"{r.status_code} {r.json().get('code', '')}".strip()
    return f"201, goal moved {r.json()['preview']['goal_offset_m']:.1f} m"


def wrong_mask(service: Service, map_id: str) -> str:
    """A keepout mask for the 4096 x 4096 map at 0.1 m (the map's is 0.05 m), a 16 MB PGM:
    issue 36 saw it decoded whole (2.4 s) before its frame was checked."""
    yaml = b"image: m.pgm\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\n"
    image = f"P5\n{HUGE} {HUGE}\n255\n".encode() + bytes(HUGE * HUGE)
    files = {"yaml": ("m.yaml", yaml), "image": ("m.pgm", image)}
    with service.client() as c:
        r = c.post(f"/maps/{map_id}/zones", files=files)
    field = r.json().get("field", "") if r.status_code != 201 else ""
    return f"{r.status_code} {field} ({len(image) / 1e6:.0f} MB)".replace("  ", " ")


def keepouts(service: Service, map_id: str) -> str:
    """256 keepout squares tiling the 4096 x 4096 map (16 x 16 of 12.8 m): issue 36 saw 8.6 s."""
    side = HUGE * RESOLUTION / 16
    corners = ((0, 0), (1, 0), (1, 1), (0, 1))
    squares = [
        [{"x": (i + a) * side, "y": (j + b) * side} for a, b in corners]
        for i in range(16)
        for j in range(16)
    ]
    with service.client() as c:
        r = c.post(f"/maps/{map_id}/zones", json={"keepout": squares})
    return str(r.status_code)


FLOOD_CLIENTS = 12
FLOOD_SECONDS = 15.0


def flood(service: Service) -> str:
    """12 clients of one tenant, for 15 s, each uploading new 1024 x 1024 maps (20 % blocked,
    a map no one sent before) with a start and a goal: an analysis and a plan each, as many
    as the pool takes. Their statuses (``503``: the tenant's share of the queue was full)."""
    grid = np.random.default_rng(7).random((1024, 1024)) < 0.2
    grid[0, :] = grid[-1, :] = False
    statuses: Counter[str] = Counter()
    counts = threading.Lock()
    seeds = iter(range(1, 1 << 20))
    end = time.monotonic() + FLOOD_SECONDS

    def client() -> None:
        with service.client() as c:
            while time.monotonic() < end:
                with counts:
                    seed = next(seeds)
                rows = rows_of(np.roll(grid, seed, axis=1))
                body = {"rows": rows, "start": [0, 0], "goal": [1023, 1023], "preset": "shortest"}
                try:
                    status = str(
                        c.post("/maps", content=orjson.dumps(body), headers=JSON).status_code
                    )
                except httpx.HTTPError as exc:
                    status = type(exc).__name__
                with counts:
                    statuses[status] += 1
                if status == "503":
                    time.sleep(0.2)

    with ThreadPoolExecutor(FLOOD_CLIENTS) as clients:
        for running in [clients.submit(client) for _ in range(FLOOD_CLIENTS)]:
            running.result()
    return ", ".join(f"{n} x {code}" for code, n in sorted(statuses.items()))

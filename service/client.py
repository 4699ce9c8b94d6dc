"""A typed Python client of the planner's HTTP API (``docs/api.md``), on httpx.

>>> from service.client import PlannerClient
>>> with PlannerClient("http://127.0.0.1:8000") as planner:  # doctest: +SKIP
...     info = planner.upload_map(rows=["....", ".@@.", "...."], start=[0, 0], goal=[2, 3])
...     step = planner.step(info.plan.plan_id, [[1, 0]], seq=0)
...     step.position, step.move
([0, 1], 'E')

:class:`PlannerClient` and :class:`AsyncPlannerClient` have the same methods. Results are small
frozen dataclasses whose attributes are the API's fields (any field the API adds later is an
attribute too, read from ``raw``, the answer's JSON). Every error answer raises an
:class:`APIError`:

APIError                 .status_code, .code, .detail, .field, .response
├── BadRequestError      400
├── NotFoundError        404  unknown map or plan (NOT_FOUND)
├── ConflictError        409  a step's seq out of order (SEQUENCE_CONFLICT)
├── PayloadTooLargeError 413  body or map over the service's limits (TOO_LARGE)
├── ValidationError      422  a bad request (INVALID_INPUT)
│   └── NoValidPathError 422  the goal cannot be reached (NO_VALID_PATH)
├── UnavailableError     503  the store is out of reach (STORE_UNAVAILABLE); .retry_after
└── ServerError          other 5xx

Network failures stay httpx's own (``httpx.TransportError``). This module imports neither
FastAPI nor the service: a client machine needs only httpx.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, NamedTuple, Self

import httpx

__all__ = [
    "APIError",
    "Analysis",
    "AsyncPlannerClient",
    "BadRequestError",
    "ConflictError",
    "MapInfo",
    "NoValidPathError",
    "NotFoundError",
    "PayloadTooLargeError",
    "Plan",
    "PlanDetail",
    "PlannerClient",
    "Preview",
    "ServerError",
    "Simulation",
    "Step",
    "UnavailableError",
    "ValidationError",
]

CellIn = Sequence[int] | Mapping[str, float]
"""A cell ``[row, col]``, or a point ``{"x": ..., "y": ...}`` in meters where the API takes one."""
Cell = list[int]
"""A cell as the API returns it: ``[row, col]``."""

# Errors


class APIError(Exception):
    """An error answer of the service."""

    def __init__(self, response: httpx.Response) -> None:
        self.response = response
        self.status_code = response.status_code
        body: Any
        try:
            body = response.json()
        except ValueError:
            body = None
        if not isinstance(body, dict):
            body = {"detail": response.text or response.reason_phrase}
        detail = body.get("detail")
        self.detail: str = detail if isinstance(detail, str) else json.dumps(detail)
        self.code: str = str(body.get("code") or f"HTTP_{response.status_code}")
        self.field: str | None = body.get("field")
        super().__init__(f"{self.status_code} {self.code}: {self.detail}")


class BadRequestError(APIError):
    """400."""


class NotFoundError(APIError):
    """404: no map or plan with that id (unknown, deleted or expired)."""


class ConflictError(APIError):
    """409: a step's ``seq`` is neither the last one nor the next one."""


class PayloadTooLargeError(APIError):
    """413: a body or a map over the service's limits."""


class ValidationError(APIError):
    """422: a request the service cannot accept; ``field`` names the input at fault."""


class NoValidPathError(ValidationError):
    """422 ``NO_VALID_PATH``: the goal cannot be reached from the start."""


class UnavailableError(APIError):
    """503: the store is out of reach for now; retry after ``retry_after`` seconds."""

    @property
    def retry_after(self) -> float | None:
        value = self.response.headers.get("retry-after")
        try:
            return float(value) if value is not None else None
        except ValueError:
            return None


class ServerError(APIError):
    """Any other 5xx."""


_ERRORS: dict[int, type[APIError]] = {
    400: BadRequestError,
    404: NotFoundError,
    409: ConflictError,
    413: PayloadTooLargeError,
    422: ValidationError,
    503: UnavailableError,
}


def _raise_for(response: httpx.Response) -> None:
    if response.is_success:
        return
    kind = _ERRORS.get(response.status_code)
    if kind is None:
        kind = ServerError if response.status_code >= 500 else APIError
    error = kind(response)
    if kind is ValidationError and error.code == "NO_VALID_PATH":
        error = NoValidPathError(response)
    raise error


# Results


@dataclass(frozen=True)
class _Result:
    raw: dict[str, Any] = field(repr=False, compare=False, kw_only=True)
    """The answer's JSON object, every field of it."""

    def __getattr__(self, name: str) -> Any:
        # Only for names that are not fields: fields the API added after this client.
        raw = self.__dict__.get("raw", {})
        if name in raw:
            return raw[name]
        raise AttributeError(f"{type(self).__name__} has no field {name!r}")


@dataclass(frozen=True)
class Analysis(_Result):
    """The map's analysis behind a plan."""

    gates: int
    tunnels: int
    narrow_fallback: bool
    cache_hit: bool
    analysis_ms: float

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Analysis:
        return cls(
            gates=d["gates"],
            tunnels=d["tunnels"],
            narrow_fallback=d["narrow_fallback"],
            cache_hit=d["cache_hit"],
            analysis_ms=d["analysis_ms"],
            raw=d,
        )


@dataclass(frozen=True)
class Preview(_Result):
    """The path the robot would follow with no dynamic obstacles, and its figures."""

    path: list[Cell]
    length: float
    arc_cost: float
    min_clearance: float
    mean_clearance: float
    contact_ratio: float
    path_xy: list[list[float]] | None = None
    """The path's cell centers in meters (None from a server before robot maps)."""
    length_m: float | None = None
    min_clearance_m: float | None = None
    mean_clearance_m: float | None = None

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Preview:
        return cls(
            path=d["path"],
            length=d["length"],
            arc_cost=d["arc_cost"],
            min_clearance=d["min_clearance"],
            mean_clearance=d["mean_clearance"],
            contact_ratio=d["contact_ratio"],
            path_xy=d.get("path_xy"),
            length_m=d.get("length_m"),
            min_clearance_m=d.get("min_clearance_m"),
            mean_clearance_m=d.get("mean_clearance_m"),
            raw=d,
        )


@dataclass(frozen=True)
class Plan(_Result):
    """A plan as ``POST /plan`` answers it."""

    plan_id: str
    map_id: str
    start: Cell
    goal: Cell
    preset: str
    params: dict[str, Any]
    status: str
    position: Cell
    analysis: Analysis
    preview: Preview

    @classmethod
    def _fields(cls, d: dict[str, Any]) -> dict[str, Any]:
        return {
            "plan_id": d["plan_id"],
            "map_id": d["map_id"],
            "start": d["start"],
            "goal": d["goal"],
            "preset": d["preset"],
            "params": d["params"],
            "status": d["status"],
            "position": d["position"],
            "analysis": Analysis.from_json(d["analysis"]),
            "preview": Preview.from_json(d["preview"]),
            "raw": d,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Plan:
        return cls(**cls._fields(d))


@dataclass(frozen=True)
class PlanDetail(Plan):
    """A plan as ``GET /plan/{plan_id}`` answers it: with the robot's progress."""

    iteration: int
    trajectory: list[Cell]
    metrics: dict[str, Any]

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> PlanDetail:
        return cls(
            **cls._fields(d),
            iteration=d["iteration"],
            trajectory=d["trajectory"],
            metrics=d["metrics"],
        )


@dataclass(frozen=True)
class MapInfo(_Result):
    """An uploaded map; ``plan`` when it was uploaded with a start and a goal. ``created`` is
    True for a map the service did not know (``201``)."""

    map_id: str
    height: int
    width: int
    free_cells: int
    plan: Plan | None
    created: bool | None
    occupied_cells: int | None = None
    unknown_cells: int | None = None
    resolution: float | None = None
    """Meters per cell (None from a server before robot maps)."""
    origin: list[float] | None = None

    @classmethod
    def from_json(cls, d: dict[str, Any], *, created: bool | None = None) -> MapInfo:
        plan = d.get("plan")
        return cls(
            map_id=d["map_id"],
            height=d["height"],
            width=d["width"],
            free_cells=d["free_cells"],
            plan=Plan.from_json(plan) if plan is not None else None,
            created=created,
            occupied_cells=d.get("occupied_cells"),
            unknown_cells=d.get("unknown_cells"),
            resolution=d.get("resolution"),
            origin=d.get("origin"),
            raw=d,
        )


@dataclass(frozen=True)
class Step(_Result):
    """The answer to a step: the cell to move to now."""

    seq: int
    previous: Cell
    position: Cell
    move: str
    status: str
    iteration: int
    path_length: float
    arc_cost: float
    remaining: float | None
    position_xy: list[float] | None = None
    """The new cell's center in meters (None from a server before robot maps)."""

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Step:
        return cls(
            seq=d["seq"],
            previous=d["previous"],
            position=d["position"],
            move=d["move"],
            status=d["status"],
            iteration=d["iteration"],
            path_length=d["path_length"],
            arc_cost=d["arc_cost"],
            remaining=d["remaining"],
            position_xy=d.get("position_xy"),
            raw=d,
        )


@dataclass(frozen=True)
class Simulation(_Result):
    """One simulated episode: the robot's trajectory and the paper's metrics."""

    trajectory: list[Cell]
    metrics: dict[str, Any]

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Simulation:
        return cls(trajectory=d["trajectory"], metrics=d["metrics"], raw=d)


# Requests, built the same for both clients


class _Request(NamedTuple):
    method: str
    url: str
    json: Any = None
    params: dict[str, Any] | None = None
    data: dict[str, str] | None = None
    files: dict[str, tuple[str, bytes, str]] | None = None


def _cell(cell: CellIn) -> Any:
    return dict(cell) if isinstance(cell, Mapping) else [int(v) for v in cell]


def _options(preset: str | None, params: Mapping[str, Any] | None) -> dict[str, Any]:
    body: dict[str, Any] = {}
    if preset is not None:
        body["preset"] = preset
    if params is not None:
        body["params"] = dict(params)
    return body


_IMAGE_LINE = re.compile(r"""^image\s*:\s*(?P<q>["']?)(?P<name>.+?)(?P=q)\s*(?:#.*)?$""", re.M)
_MEDIA = {".png": "image/png", ".bmp": "image/bmp", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}


def _given(**fields: Any) -> dict[str, Any]:
    """The fields that are not ``None``: ``None`` is "not sent", the server's default."""
    return {name: value for name, value in fields.items() if value is not None}


def _upload_map(
    grid: Sequence[Sequence[int]] | None,
    rows: Sequence[str] | None,
    occupancy_grid: Mapping[str, Any] | None,
    yaml: str | Path | None,
    start: CellIn | None,
    goal: CellIn | None,
    preset: str | None,
    params: Mapping[str, Any] | None,
    frame: Mapping[str, Any],
) -> _Request:
    kinds = (("grid", grid), ("rows", rows), ("occupancy_grid", occupancy_grid), ("yaml", yaml))
    given = [name for name, v in kinds if v is not None]
    if len(given) != 1:
        msg = (
            "upload_map takes exactly one of grid, rows, occupancy_grid and yaml; "
            f"got {given or 'none'}"
        )
        raise TypeError(msg)
    extra: dict[str, Any] = _options(preset, params)
    if start is not None:
        extra["start"] = _cell(start)
    if goal is not None:
        extra["goal"] = _cell(goal)
    extra.update(_given(**frame))
    if grid is not None:
        return _Request("POST", "/maps", json={"grid": [list(row) for row in grid], **extra})
    if rows is not None:
        return _Request("POST", "/maps", json={"rows": list(rows), **extra})
    if occupancy_grid is not None:
        return _Request("POST", "/maps", json={"occupancy_grid": dict(occupancy_grid), **extra})
    assert yaml is not None
    path = Path(yaml)
    text = path.read_bytes()
    match = _IMAGE_LINE.search(text.decode("utf-8"))
    if match is None:
        raise ValueError(f"{path}: no 'image:' key names the map's image")
    image = path.parent / match.group("name")
    media = _MEDIA.get(image.suffix.lower(), "image/x-portable-graymap")
    files = {
        "yaml": (path.name, text, "application/yaml"),
        "image": (image.name, image.read_bytes(), media),
    }
    # Other fields ride along as form fields, each value as JSON.
    data = {
        key: value if isinstance(value, str) else json.dumps(value) for key, value in extra.items()
    }
    return _Request("POST", "/maps", data=data or None, files=files)


def _plan(
    map_id: str, start: CellIn, goal: CellIn, preset: str | None, params: Mapping[str, Any] | None
) -> _Request:
    body = {
        "map_id": map_id,
        "start": _cell(start),
        "goal": _cell(goal),
        **_options(preset, params),
    }
    return _Request("POST", "/plan", json=body)


def _step(
    plan_id: str, dynamic_obstacles: Sequence[Any], seq: int | None, position: CellIn | None
) -> _Request:
    obstacles = [o if isinstance(o, Mapping) else _cell(o) for o in dynamic_obstacles]
    body: dict[str, Any] = {"dynamic_obstacles": obstacles}
    if seq is not None:
        body["seq"] = seq
    if position is not None:
        body["position"] = _cell(position)
    return _Request("POST", f"/plan/{plan_id}/step", json=body)


def _simulate(
    map_id: str,
    start: CellIn,
    goal: CellIn,
    dynamic_count: int,
    seed: int,
    preset: str | None,
    params: Mapping[str, Any] | None,
    options: Mapping[str, Any],
) -> _Request:
    body: dict[str, Any] = {
        "start": _cell(start),
        "goal": _cell(goal),
        "dynamic_count": dynamic_count,
        "seed": seed,
        **_options(preset, params),
        **_given(**options),
    }
    return _Request("POST", f"/maps/{map_id}/simulate", json=body)


def _png(response: httpx.Response) -> bytes:
    if not response.content.startswith(b"\x89PNG"):
        msg = f"expected a PNG, got {response.headers.get('content-type')!r}"
        raise ValueError(msg)
    return response.content


class _Base:
    def __init__(self, base_url: str) -> None:
        self.base_url = base_url.rstrip("/")


class PlannerClient(_Base):
    """The API over a blocking ``httpx.Client``; close it, or use it as a context manager.

    ``transport`` and ``headers`` go to httpx (a mock transport in tests, an ``X-Request-ID``).
    """

    def __init__(
        self,
        base_url: str,
        *,
        timeout: float = 60.0,
        headers: Mapping[str, str] | None = None,
        transport: httpx.BaseTransport | None = None,
    ) -> None:
        super().__init__(base_url)
        self._http = httpx.Client(
            base_url=self.base_url, timeout=timeout, headers=headers, transport=transport
        )

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        self._http.close()

    def _send(self, request: _Request) -> httpx.Response:
        method, url, body, params, data, files = request
        response = self._http.request(method, url, json=body, params=params, data=data, files=files)
        _raise_for(response)
        return response

    def upload_map(
        self,
        *,
        grid: Sequence[Sequence[int]] | None = None,
        rows: Sequence[str] | None = None,
        occupancy_grid: Mapping[str, Any] | None = None,
        yaml: str | Path | None = None,
        resolution: float | None = None,
        origin: Sequence[float] | None = None,
        start: CellIn | None = None,
        goal: CellIn | None = None,
        preset: str | None = None,
        params: Mapping[str, Any] | None = None,
    ) -> MapInfo:
        """Upload a map as a ``grid`` of 0/1/-1 or Moving AI ``rows`` (either with an optional
        ``resolution`` and ``origin`` ``[x, y, yaw]``), a ``nav_msgs/OccupancyGrid`` as rosbridge
        writes it (``occupancy_grid``), or a ROS map ``yaml`` file (its image, which the YAML
        names, is read beside it); with ``start`` and ``goal``, also plan. ``None`` is not sent.
        """
        frame = {"resolution": resolution, "origin": None if origin is None else list(origin)}
        request = _upload_map(grid, rows, occupancy_grid, yaml, start, goal, preset, params, frame)
        r = self._send(request)
        return MapInfo.from_json(r.json(), created=r.status_code == 201)

    def get_map(self, map_id: str) -> MapInfo:
        return MapInfo.from_json(self._send(_Request("GET", f"/maps/{map_id}")).json())

    def plan(
        self,
        map_id: str,
        start: CellIn,
        goal: CellIn,
        *,
        preset: str | None = None,
        params: Mapping[str, Any] | None = None,
    ) -> Plan:
        return Plan.from_json(self._send(_plan(map_id, start, goal, preset, params)).json())

    def get_plan(self, plan_id: str) -> PlanDetail:
        return PlanDetail.from_json(self._send(_Request("GET", f"/plan/{plan_id}")).json())

    def delete_plan(self, plan_id: str) -> None:
        self._send(_Request("DELETE", f"/plan/{plan_id}"))

    def step(
        self,
        plan_id: str,
        dynamic_obstacles: Sequence[Any],
        *,
        seq: int | None = None,
        position: CellIn | None = None,
    ) -> Step:
        """Report the dynamic obstacles (cells, or circles ``{"x", "y", "radius"}``); the answer
        is the move to make now. Retrying the same ``seq`` is safe."""
        return Step.from_json(self._send(_step(plan_id, dynamic_obstacles, seq, position)).json())

    def simulate(
        self,
        map_id: str,
        start: CellIn,
        goal: CellIn,
        *,
        dynamic_count: int,
        seed: int,
        preset: str | None = None,
        params: Mapping[str, Any] | None = None,
        max_steps: int | None = None,
        obstacle_motion: str | None = None,
        robot_radius: float | None = None,
        unknown: str | None = None,
        allow_narrow: bool | None = None,
    ) -> Simulation:
        """One seeded episode among ``dynamic_count`` moving obstacles (the paper's
        experiment); the other arguments are ``SimulationCreate``'s fields, ``None`` not sent."""
        options = {
            "max_steps": max_steps,
            "obstacle_motion": obstacle_motion,
            "robot_radius": robot_radius,
            "unknown": unknown,
            "allow_narrow": allow_narrow,
        }
        request = _simulate(map_id, start, goal, dynamic_count, seed, preset, params, options)
        return Simulation.from_json(self._send(request).json())

    def render_map(self, map_id: str, **query: Any) -> bytes:
        """The map and its analysis as PNG bytes (``preset=``, ``field=``, ``cell=``)."""
        return _png(self._send(_Request("GET", f"/maps/{map_id}/render.png", params=query)))

    def render_plan(self, plan_id: str, **query: Any) -> bytes:
        """The plan and the robot's trajectory so far as PNG bytes (``field=``, ``cell=``)."""
        return _png(self._send(_Request("GET", f"/plan/{plan_id}/render.png", params=query)))


class AsyncPlannerClient(_Base):
    """:class:`PlannerClient`'s methods as coroutines, over an ``httpx.AsyncClient``."""

    def __init__(
        self,
        base_url: str,
        *,
        timeout: float = 60.0,
        headers: Mapping[str, str] | None = None,
        transport: httpx.AsyncBaseTransport | None = None,
    ) -> None:
        super().__init__(base_url)
        self._http = httpx.AsyncClient(
            base_url=self.base_url, timeout=timeout, headers=headers, transport=transport
        )

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        await self.aclose()

    async def aclose(self) -> None:
        await self._http.aclose()

    async def _send(self, request: _Request) -> httpx.Response:
        method, url, body, params, data, files = request
        response = await self._http.request(
            method, url, json=body, params=params, data=data, files=files
        )
        _raise_for(response)
        return response

    async def upload_map(
        self,
        *,
        grid: Sequence[Sequence[int]] | None = None,
        rows: Sequence[str] | None = None,
        occupancy_grid: Mapping[str, Any] | None = None,
        yaml: str | Path | None = None,
        resolution: float | None = None,
        origin: Sequence[float] | None = None,
        start: CellIn | None = None,
        goal: CellIn | None = None,
        preset: str | None = None,
        params: Mapping[str, Any] | None = None,
    ) -> MapInfo:
        frame = {"resolution": resolution, "origin": None if origin is None else list(origin)}
        request = _upload_map(grid, rows, occupancy_grid, yaml, start, goal, preset, params, frame)
        r = await self._send(request)
        return MapInfo.from_json(r.json(), created=r.status_code == 201)

    async def get_map(self, map_id: str) -> MapInfo:
        return MapInfo.from_json((await self._send(_Request("GET", f"/maps/{map_id}"))).json())

    async def plan(
        self,
        map_id: str,
        start: CellIn,
        goal: CellIn,
        *,
        preset: str | None = None,
        params: Mapping[str, Any] | None = None,
    ) -> Plan:
        r = await self._send(_plan(map_id, start, goal, preset, params))
        return Plan.from_json(r.json())

    async def get_plan(self, plan_id: str) -> PlanDetail:
        r = await self._send(_Request("GET", f"/plan/{plan_id}"))
        return PlanDetail.from_json(r.json())

    async def delete_plan(self, plan_id: str) -> None:
        await self._send(_Request("DELETE", f"/plan/{plan_id}"))

    async def step(
        self,
        plan_id: str,
        dynamic_obstacles: Sequence[Any],
        *,
        seq: int | None = None,
        position: CellIn | None = None,
    ) -> Step:
        r = await self._send(_step(plan_id, dynamic_obstacles, seq, position))
        return Step.from_json(r.json())

    async def simulate(
        self,
        map_id: str,
        start: CellIn,
        goal: CellIn,
        *,
        dynamic_count: int,
        seed: int,
        preset: str | None = None,
        params: Mapping[str, Any] | None = None,
        max_steps: int | None = None,
        obstacle_motion: str | None = None,
        robot_radius: float | None = None,
        unknown: str | None = None,
        allow_narrow: bool | None = None,
    ) -> Simulation:
        options = {
            "max_steps": max_steps,
            "obstacle_motion": obstacle_motion,
            "robot_radius": robot_radius,
            "unknown": unknown,
            "allow_narrow": allow_narrow,
        }
        request = _simulate(map_id, start, goal, dynamic_count, seed, preset, params, options)
        return Simulation.from_json((await self._send(request)).json())

    async def render_map(self, map_id: str, **query: Any) -> bytes:
        r = await self._send(_Request("GET", f"/maps/{map_id}/render.png", params=query))
        return _png(r)

    async def render_plan(self, plan_id: str, **query: Any) -> bytes:
        r = await self._send(_Request("GET", f"/plan/{plan_id}/render.png", params=query))
        return _png(r)

"""The planner's clients, sync and async, on httpx: each call is built once (a request and how
to read its answer) and sent by either client."""

from __future__ import annotations

import json
import re
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, Generic, Self, TypeVar, Unpack

import httpx

from schemas import (
    AnalysisPublic,
    FleetPublic,
    LiveMarksPublic,
    MapfPublic,
    MapPublic,
    NavPath,
    ObservationPublic,
    PassagesPublic,
    PlanDetail,
    PlanPublic,
    PreviewPublic,
    SimulationPublic,
    StepPublic,
)
from service.client.calls import Call, R, as_cell, decode, json_body, png
from service.client.errors import MapFileError, raise_for
from service.client.fields import (
    CellIn,
    MapfFields,
    PlanFields,
    PointIn,
    RouteFields,
    SimulateFields,
    StepFields,
    UploadMapFields,
    ZonesFields,
)

__all__ = [
    "Analysis",
    "AsyncPlannerClient",
    "Fleet",
    "LiveMarks",
    "MapInfo",
    "Mapf",
    "MapfFields",
    "NavPath",
    "Observation",
    "Passages",
    "Plan",
    "PlanDetail",
    "PlanFields",
    "PlannerClient",
    "Preview",
    "RouteFields",
    "SimulateFields",
    "Simulation",
    "Step",
    "StepFields",
    "UploadMapFields",
    "ZonesFields",
]

# Results: the response models, under the names this client has always given them.
Analysis = AnalysisPublic
Preview = PreviewPublic
Plan = PlanPublic
Step = StepPublic
Simulation = SimulationPublic
Fleet = FleetPublic
Mapf = MapfPublic
Passages = PassagesPublic
Observation = ObservationPublic
LiveMarks = LiveMarksPublic


class MapInfo(MapPublic):
    """An uploaded map; ``plan`` when it was uploaded with a start and a goal."""

    created: bool | None = None
    """From ``upload_map``: True for a map the service did not know (``201``), else False."""


def _created(response: httpx.Response) -> MapInfo:
    info = MapInfo.model_validate_json(response.content)
    info.created = response.status_code == 201
    return info


_IMAGE_LINE = re.compile(r"""^image\s*:\s*(?P<q>["']?)(?P<name>.+?)(?P=q)\s*(?:#.*)?$""", re.M)
_MEDIA = {".png": "image/png", ".bmp": "image/bmp", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}


def _upload_map(fields: UploadMapFields) -> Call[MapInfo]:
    kinds = ("grid", "rows", "occupancy_grid", "yaml")
    given = [name for name in kinds if fields.get(name) is not None]
    if len(given) != 1:
        got = given or "none"
        raise TypeError(f"upload_map takes exactly one of grid, rows, occupancy_grid, yaml: {got}")
    yaml = fields.get("yaml")
    if yaml is None:
        return Call("POST", "/maps", _created, {"json": json_body(fields)})
    extra = json_body({k: v for k, v in fields.items() if k != "yaml"})
    return Call("POST", "/maps", _created, _multipart(yaml, extra))


def _multipart(yaml: str | Path, extra: Mapping[str, Any]) -> dict[str, Any]:
    """A map_server YAML file and the image it names (read beside it) as the parts ``yaml``
    and ``image``; the other fields ride along as form fields, each value as JSON."""
    path = Path(yaml)
    text = _read(path, f"the map YAML {str(path)!r}")
    match = _IMAGE_LINE.search(text.decode("utf-8", "replace"))
    if match is None:
        raise MapFileError(f"{path}: no 'image:' key names the map's image", path)
    image = path.parent / match.group("name")
    media = _MEDIA.get(image.suffix.lower(), "image/x-portable-graymap")
    pixels = _read(image, f"the image {str(image)!r} that {path.name} names")
    files = {
        "yaml": (path.name, text, "application/yaml"),
        "image": (image.name, pixels, media),
    }
    data = {k: v if isinstance(v, str) else json.dumps(v) for k, v in extra.items()}
    return {"data": data or None, "files": files}


def _point(point: PointIn) -> dict[str, float]:
    if isinstance(point, Mapping):
        return {"x": point["x"], "y": point["y"]}
    x, y = point
    return {"x": x, "y": y}


def _add_zones(map_id: str, fields: ZonesFields) -> Call[MapInfo]:
    extra: dict[str, Any] = {}
    keepout, speed = fields.get("keepout"), fields.get("speed")
    if keepout is not None:
        extra["keepout"] = [[_point(p) for p in polygon] for polygon in keepout]
    if speed is not None:
        extra["speed"] = [
            {"polygon": [_point(p) for p in zone["polygon"]], "max_speed": zone["max_speed"]}
            for zone in speed
        ]
    url = f"/maps/{map_id}/zones"
    yaml = fields.get("yaml")
    if yaml is None:
        return Call("POST", url, _created, {"json": extra})
    return Call("POST", url, _created, _multipart(yaml, extra))


def _read(path: Path, what: str) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise MapFileError(f"{what} does not exist", path) from None
    except OSError as exc:
        raise MapFileError(f"{what} cannot be read: {exc.strerror}", path) from None


def _get_map(map_id: str) -> Call[MapInfo]:
    return Call("GET", f"/maps/{map_id}", decode(MapInfo))


def _passages(map_id: str, robot_radius: float, max_width: float | None) -> Call[Passages]:
    query = json_body({"robot_radius": robot_radius, "max_width": max_width})
    return Call("GET", f"/maps/{map_id}/passages", decode(Passages), {"params": query})


def _plan(map_id: str, start: CellIn, goal: CellIn, options: RouteFields) -> Call[Plan]:
    body = json_body({"map_id": map_id, "start": start, "goal": goal, **options})
    return Call("POST", "/plan", decode(Plan), {"json": body})


def _get_plan(plan_id: str) -> Call[PlanDetail]:
    return Call("GET", f"/plan/{plan_id}", decode(PlanDetail))


def _path(plan_id: str, frame_id: str | None) -> Call[NavPath]:
    query = {} if frame_id is None else {"frame_id": frame_id}
    return Call("GET", f"/plan/{plan_id}/path", decode(NavPath), {"params": query})


def _delete_plan(plan_id: str) -> Call[None]:
    return Call("DELETE", f"/plan/{plan_id}", lambda response: None)


def _step(plan_id: str, dynamic_obstacles: Sequence[Any], fields: StepFields) -> Call[Step]:
    obstacles = [o if isinstance(o, Mapping) else as_cell(o) for o in dynamic_obstacles]
    body = {"dynamic_obstacles": obstacles, **json_body(fields)}
    return Call("POST", f"/plan/{plan_id}/step", decode(Step), {"json": body})


def _simulate(map_id: str, start: CellIn, goal: CellIn, fields: SimulateFields) -> Call[Simulation]:
    body = json_body({"start": start, "goal": goal, **fields})
    return Call("POST", f"/maps/{map_id}/simulate", decode(Simulation), {"json": body})


def _render(kind: str, id_: str, query: dict[str, Any]) -> Call[bytes]:
    return Call("GET", f"/{kind}/{id_}/render.png", png, {"params": query})


def _change_goal(plan_id: str, goal: CellIn) -> Call[PlanDetail]:
    body = {"goal": as_cell(goal)}
    return Call("PATCH", f"/plan/{plan_id}", decode(PlanDetail), {"json": body})


def _mapf(map_id: str, agents: Sequence[tuple[CellIn, CellIn]], fields: MapfFields) -> Call[Mapf]:
    body = json_body(
        {"agents": [{"start": as_cell(s), "goal": as_cell(g)} for s, g in agents], **fields}
    )
    return Call("POST", f"/maps/{map_id}/mapf", decode(Mapf), {"json": body})


def _observe(
    map_id: str, scan: Mapping[str, Any], scan_pose: Mapping[str, float], robot_radius: float
) -> Call[Observation]:
    body = {"scan": dict(scan), "scan_pose": dict(scan_pose), "robot_radius": robot_radius}
    return Call("POST", f"/maps/{map_id}/observations", decode(Observation), {"json": body})


def _live(map_id: str) -> Call[LiveMarks]:
    return Call("GET", f"/maps/{map_id}/live", decode(LiveMarks))


def _fleet(name: str, ahead: bool) -> Call[Fleet]:
    query = {"ahead": True} if ahead else {}
    return Call("GET", f"/fleets/{name}", decode(Fleet), {"params": query})


T = TypeVar("T", httpx.BaseTransport, httpx.AsyncBaseTransport)
H = TypeVar("H", httpx.Client, httpx.AsyncClient)


class _Client(ABC, Generic[T, H]):
    """What both clients share: the base URL and the httpx client's options."""

    def __init__(
        self,
        base_url: str,
        *,
        timeout: float = 60.0,
        headers: Mapping[str, str] | None = None,
        transport: T | None = None,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self._http: H = self._open(
            base_url=self.base_url, timeout=timeout, headers=headers, transport=transport
        )

    @abstractmethod
    def _open(self, **options: Any) -> H: ...


class PlannerClient(_Client[httpx.BaseTransport, httpx.Client]):
    """The API over a blocking ``httpx.Client``; close it, or use it as a context manager.

    ``timeout``, ``transport`` and ``headers`` go to httpx (a mock transport in tests, an
    ``X-Request-ID``).
    """

    def _open(self, **options: Any) -> httpx.Client:
        return httpx.Client(**options)

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

    def _call(self, call: Call[R]) -> R:
        response = self._http.request(call.method, call.url, **call.content)
        raise_for(response)
        return call.answer(response)

    def upload_map(self, **fields: Unpack[UploadMapFields]) -> MapInfo:
        """Upload a map as a ``grid`` of 0/1/-1 or Moving AI ``rows`` (either with an optional
        ``resolution`` and ``origin`` ``[x, y, yaw]``), a ``nav_msgs/OccupancyGrid`` as rosbridge
        writes it (``occupancy_grid``), or a ROS map ``yaml`` file (its image, which the YAML
        names, is read beside it); with ``start`` and ``goal`` (and the plan's options), also
        plan. ``None`` is not sent."""
        return self._call(_upload_map(fields))

    def get_map(self, map_id: str) -> MapInfo:
        return self._call(_get_map(map_id))

    def passages(
        self, map_id: str, robot_radius: float, max_width: float | None = None
    ) -> Passages:
        """The map's narrow passages for a robot of ``robot_radius`` meters (at most
        ``max_width`` wide, by default the server's ``2 * robot_radius + 0.3``)."""
        return self._call(_passages(map_id, robot_radius, max_width))

    def add_zones(self, map_id: str, **fields: Unpack[ZonesFields]) -> MapInfo:
        """Zone an uploaded map: ``keepout`` polygons, ``speed`` zones, or a keepout filter
        mask's ``yaml`` file; the answer is the zoned map (a new ``map_id``, its ``zones``).
        ``None`` is not sent."""
        return self._call(_add_zones(map_id, fields))

    def plan(
        self, map_id: str, start: CellIn, goal: CellIn, **options: Unpack[RouteFields]
    ) -> Plan:
        """Plan on an uploaded map; ``options`` are ``PlanCreate``'s (``waypoints`` among them),
        ``None`` not sent."""
        return self._call(_plan(map_id, start, goal, options))

    def get_plan(self, plan_id: str) -> PlanDetail:
        return self._call(_get_plan(plan_id))

    def path(self, plan_id: str, frame_id: str | None = None) -> NavPath:
        """The plan's poses as a ``nav_msgs/Path`` (rosbridge's JSON), in ``frame_id`` (the
        server's default: ``map``)."""
        return self._call(_path(plan_id, frame_id))

    def delete_plan(self, plan_id: str) -> None:
        self._call(_delete_plan(plan_id))

    def fleet(self, name: str, *, ahead: bool = False) -> Fleet:
        """A fleet's robots (plans made with ``fleet=name``), each one's route left and whom it
        waits for, and its last solve; with ``ahead``, each robot's path ahead too."""
        return self._call(_fleet(name, ahead))

    def change_goal(self, plan_id: str, goal: CellIn) -> PlanDetail:
        """A fleet robot's new goal: its fleet is solved again at its next step."""
        return self._call(_change_goal(plan_id, goal))

    def mapf(
        self, map_id: str, agents: Sequence[tuple[CellIn, CellIn]], **fields: Unpack[MapfFields]
    ) -> Mapf:
        """Agents (``(start, goal)`` cells) planned together on the map's roadmap."""
        return self._call(_mapf(map_id, agents, fields))

    def step(
        self, plan_id: str, dynamic_obstacles: Sequence[Any], **fields: Unpack[StepFields]
    ) -> Step:
        """Report the dynamic obstacles (cells, or circles ``{"x", "y", "radius"}``); the answer
        is the move to make now. Retrying the same ``seq`` is safe."""
        return self._call(_step(plan_id, dynamic_obstacles, fields))

    def simulate(
        self, map_id: str, start: CellIn, goal: CellIn, **fields: Unpack[SimulateFields]
    ) -> Simulation:
        """One seeded episode among ``dynamic_count`` moving obstacles (the paper's
        experiment); the other fields are ``SimulationCreate``'s, ``None`` not sent."""
        return self._call(_simulate(map_id, start, goal, fields))

    def observe(
        self,
        map_id: str,
        scan: Mapping[str, Any],
        scan_pose: Mapping[str, float],
        *,
        robot_radius: float = 0.0,
    ) -> Observation:
        """Report a laser scan (``sensor_msgs/LaserScan`` as rosbridge JSON) taken at
        ``scan_pose`` ``{x, y, yaw}``: its returns mark the map's live layer, its rays clear
        it; every plan on the map steps around the marks."""
        return self._call(_observe(map_id, scan, scan_pose, robot_radius))

    def live(self, map_id: str) -> LiveMarks:
        """The map's live marks now, as cells and points."""
        return self._call(_live(map_id))

    def render_live(self, map_id: str, **query: Any) -> bytes:
        """The map with its live marks as PNG bytes (``cell=``)."""
        return self._call(Call("GET", f"/maps/{map_id}/live.png", png, {"params": query}))

    def render_map(self, map_id: str, **query: Any) -> bytes:
        """The map and its analysis as PNG bytes (``preset=``, ``field=``, ``cell=``)."""
        return self._call(_render("maps", map_id, query))

    def render_plan(self, plan_id: str, **query: Any) -> bytes:
        """The plan and the robot's trajectory so far as PNG bytes (``field=``, ``cell=``)."""
        return self._call(_render("plan", plan_id, query))


class AsyncPlannerClient(_Client[httpx.AsyncBaseTransport, httpx.AsyncClient]):
    """:class:`PlannerClient`'s methods as coroutines, over an ``httpx.AsyncClient``."""

    def _open(self, **options: Any) -> httpx.AsyncClient:
        return httpx.AsyncClient(**options)

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

    async def _call(self, call: Call[R]) -> R:
        response = await self._http.request(call.method, call.url, **call.content)
        raise_for(response)
        return call.answer(response)

    async def upload_map(self, **fields: Unpack[UploadMapFields]) -> MapInfo:
        return await self._call(_upload_map(fields))

    async def get_map(self, map_id: str) -> MapInfo:
        return await self._call(_get_map(map_id))

    async def passages(
        self, map_id: str, robot_radius: float, max_width: float | None = None
    ) -> Passages:
        return await self._call(_passages(map_id, robot_radius, max_width))

    async def add_zones(self, map_id: str, **fields: Unpack[ZonesFields]) -> MapInfo:
        return await self._call(_add_zones(map_id, fields))

    async def plan(
        self, map_id: str, start: CellIn, goal: CellIn, **options: Unpack[RouteFields]
    ) -> Plan:
        return await self._call(_plan(map_id, start, goal, options))

    async def get_plan(self, plan_id: str) -> PlanDetail:
        return await self._call(_get_plan(plan_id))

    async def path(self, plan_id: str, frame_id: str | None = None) -> NavPath:
        return await self._call(_path(plan_id, frame_id))

    async def delete_plan(self, plan_id: str) -> None:
        await self._call(_delete_plan(plan_id))

    async def fleet(self, name: str, *, ahead: bool = False) -> Fleet:
        return await self._call(_fleet(name, ahead))

    async def change_goal(self, plan_id: str, goal: CellIn) -> PlanDetail:
        return await self._call(_change_goal(plan_id, goal))

    async def mapf(
        self, map_id: str, agents: Sequence[tuple[CellIn, CellIn]], **fields: Unpack[MapfFields]
    ) -> Mapf:
        return await self._call(_mapf(map_id, agents, fields))

    async def step(
        self, plan_id: str, dynamic_obstacles: Sequence[Any], **fields: Unpack[StepFields]
    ) -> Step:
        return await self._call(_step(plan_id, dynamic_obstacles, fields))

    async def simulate(
        self, map_id: str, start: CellIn, goal: CellIn, **fields: Unpack[SimulateFields]
    ) -> Simulation:
        return await self._call(_simulate(map_id, start, goal, fields))

    async def observe(
        self,
        map_id: str,
        scan: Mapping[str, Any],
        scan_pose: Mapping[str, float],
        *,
        robot_radius: float = 0.0,
    ) -> Observation:
        return await self._call(_observe(map_id, scan, scan_pose, robot_radius))

    async def live(self, map_id: str) -> LiveMarks:
        return await self._call(_live(map_id))

    async def render_live(self, map_id: str, **query: Any) -> bytes:
        return await self._call(Call("GET", f"/maps/{map_id}/live.png", png, {"params": query}))

    async def render_map(self, map_id: str, **query: Any) -> bytes:
        return await self._call(_render("maps", map_id, query))

    async def render_plan(self, plan_id: str, **query: Any) -> bytes:
        return await self._call(_render("plan", plan_id, query))

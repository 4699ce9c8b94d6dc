"""The planner's clients, sync and async, on httpx: each call is built once (a request and how
to read its answer) and sent by either client."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from types import TracebackType
from typing import Any, Generic, Self, TypeVar, Unpack

import httpx

from schemas import NavPath, PlanDetail
from service.client import endpoints
from service.client.calls import Call, R
from service.client.endpoints import (
    Analysis,
    Fleet,
    LiveMarks,
    Mapf,
    MapInfo,
    Observation,
    Passages,
    Plan,
    Preview,
    Simulation,
    Step,
)
from service.client.errors import raise_for
from service.client.fields import (
    CellIn,
    MapfFields,
    PlanFields,
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
        return self._call(endpoints.upload_map(fields))

    def get_map(self, map_id: str) -> MapInfo:
        return self._call(endpoints.get_map(map_id))

    def passages(
        self, map_id: str, robot_radius: float, max_width: float | None = None
    ) -> Passages:
        """The map's narrow passages for a robot of ``robot_radius`` meters (at most
        ``max_width`` wide, by default the server's ``2 * robot_radius + 0.3``)."""
        return self._call(endpoints.passages(map_id, robot_radius, max_width))

    def add_zones(self, map_id: str, **fields: Unpack[ZonesFields]) -> MapInfo:
        """Zone an uploaded map: ``keepout`` polygons, ``speed`` zones, or a keepout filter
        mask's ``yaml`` file; the answer is the zoned map (a new ``map_id``, its ``zones``).
        ``None`` is not sent."""
        return self._call(endpoints.add_zones(map_id, fields))

    def plan(
        self, map_id: str, start: CellIn, goal: CellIn, **options: Unpack[RouteFields]
    ) -> Plan:
        """Plan on an uploaded map; ``options`` are ``PlanCreate``'s (``waypoints`` among them),
        ``None`` not sent."""
        return self._call(endpoints.plan(map_id, start, goal, options))

    def get_plan(self, plan_id: str) -> PlanDetail:
        return self._call(endpoints.get_plan(plan_id))

    def path(self, plan_id: str, frame_id: str | None = None) -> NavPath:
        """The plan's poses as a ``nav_msgs/Path`` (rosbridge's JSON), in ``frame_id`` (the
        server's default: ``map``)."""
        return self._call(endpoints.path(plan_id, frame_id))

    def delete_plan(self, plan_id: str) -> None:
        self._call(endpoints.delete_plan(plan_id))

    def fleet(self, name: str, *, ahead: bool = False) -> Fleet:
        """A fleet's robots (plans made with ``fleet=name``), each one's route left and whom it
        waits for, and its last solve; with ``ahead``, each robot's path ahead too."""
        return self._call(endpoints.fleet(name, ahead))

    def change_goal(self, plan_id: str, goal: CellIn) -> PlanDetail:
        """A fleet robot's new goal: its fleet is solved again at its next step."""
        return self._call(endpoints.change_goal(plan_id, goal))

    def mapf(
        self, map_id: str, agents: Sequence[tuple[CellIn, CellIn]], **fields: Unpack[MapfFields]
    ) -> Mapf:
        """Agents (``(start, goal)`` cells) planned together on the map's roadmap."""
        return self._call(endpoints.mapf(map_id, agents, fields))

    def step(
        self, plan_id: str, dynamic_obstacles: Sequence[Any], **fields: Unpack[StepFields]
    ) -> Step:
        """Report the dynamic obstacles (cells, or circles ``{"x", "y", "radius"}``); the answer
        is the move to make now. Retrying the same ``seq`` is safe."""
        return self._call(endpoints.step(plan_id, dynamic_obstacles, fields))

    def simulate(
        self, map_id: str, start: CellIn, goal: CellIn, **fields: Unpack[SimulateFields]
    ) -> Simulation:
        """One seeded episode among ``dynamic_count`` moving obstacles (the paper's
        experiment); the other fields are ``SimulationCreate``'s, ``None`` not sent."""
        return self._call(endpoints.simulate(map_id, start, goal, fields))

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
        return self._call(endpoints.observe(map_id, scan, scan_pose, robot_radius))

    def live(self, map_id: str) -> LiveMarks:
        """The map's live marks now, as cells and points."""
        return self._call(endpoints.live(map_id))

    def render_live(self, map_id: str, **query: Any) -> bytes:
        """The map with its live marks as PNG bytes (``cell=``)."""
        return self._call(endpoints.render(f"/maps/{map_id}/live.png", query))

    def render_map(self, map_id: str, **query: Any) -> bytes:
        """The map and its analysis as PNG bytes (``preset=``, ``field=``, ``cell=``, ``crop=``)."""
        return self._call(endpoints.render(f"/maps/{map_id}/render.png", query))

    def render_plan(self, plan_id: str, **query: Any) -> bytes:
        """The plan and the robot's trajectory so far as PNG bytes (``field=``, ``cell=``,
        ``crop=``)."""
        return self._call(endpoints.render(f"/plan/{plan_id}/render.png", query))


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
        return await self._call(endpoints.upload_map(fields))

    async def get_map(self, map_id: str) -> MapInfo:
        return await self._call(endpoints.get_map(map_id))

    async def passages(
        self, map_id: str, robot_radius: float, max_width: float | None = None
    ) -> Passages:
        return await self._call(endpoints.passages(map_id, robot_radius, max_width))

    async def add_zones(self, map_id: str, **fields: Unpack[ZonesFields]) -> MapInfo:
        return await self._call(endpoints.add_zones(map_id, fields))

    async def plan(
        self, map_id: str, start: CellIn, goal: CellIn, **options: Unpack[RouteFields]
    ) -> Plan:
        return await self._call(endpoints.plan(map_id, start, goal, options))

    async def get_plan(self, plan_id: str) -> PlanDetail:
        return await self._call(endpoints.get_plan(plan_id))

    async def path(self, plan_id: str, frame_id: str | None = None) -> NavPath:
        return await self._call(endpoints.path(plan_id, frame_id))

    async def delete_plan(self, plan_id: str) -> None:
        await self._call(endpoints.delete_plan(plan_id))

    async def fleet(self, name: str, *, ahead: bool = False) -> Fleet:
        return await self._call(endpoints.fleet(name, ahead))

    async def change_goal(self, plan_id: str, goal: CellIn) -> PlanDetail:
        return await self._call(endpoints.change_goal(plan_id, goal))

    async def mapf(
        self, map_id: str, agents: Sequence[tuple[CellIn, CellIn]], **fields: Unpack[MapfFields]
    ) -> Mapf:
        return await self._call(endpoints.mapf(map_id, agents, fields))

    async def step(
        self, plan_id: str, dynamic_obstacles: Sequence[Any], **fields: Unpack[StepFields]
    ) -> Step:
        return await self._call(endpoints.step(plan_id, dynamic_obstacles, fields))

    async def simulate(
        self, map_id: str, start: CellIn, goal: CellIn, **fields: Unpack[SimulateFields]
    ) -> Simulation:
        return await self._call(endpoints.simulate(map_id, start, goal, fields))

    async def observe(
        self,
        map_id: str,
        scan: Mapping[str, Any],
        scan_pose: Mapping[str, float],
        *,
        robot_radius: float = 0.0,
    ) -> Observation:
        return await self._call(endpoints.observe(map_id, scan, scan_pose, robot_radius))

    async def live(self, map_id: str) -> LiveMarks:
        return await self._call(endpoints.live(map_id))

    async def render_live(self, map_id: str, **query: Any) -> bytes:
        return await self._call(endpoints.render(f"/maps/{map_id}/live.png", query))

    async def render_map(self, map_id: str, **query: Any) -> bytes:
        return await self._call(endpoints.render(f"/maps/{map_id}/render.png", query))

    async def render_plan(self, plan_id: str, **query: Any) -> bytes:
        return await self._call(endpoints.render(f"/plan/{plan_id}/render.png", query))

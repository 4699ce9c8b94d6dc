"""The API's calls, one a function: each builds its request and says how to read its answer
(a :class:`~service.client.calls.Call`), sent by either client (:mod:`service.client.clients`).
The results are the response models of :mod:`schemas`, under the client's names."""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

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
from service.client.calls import Call, as_cell, decode, json_body, png
from service.client.errors import MapFileError
from service.client.fields import (
    CellIn,
    MapfFields,
    PointIn,
    RouteFields,
    SimulateFields,
    StepFields,
    UploadMapFields,
    ZonesFields,
)

__all__ = [
    "Analysis",
    "Fleet",
    "LiveMarks",
    "MapInfo",
    "Mapf",
    "Observation",
    "Passages",
    "Plan",
    "Preview",
    "Simulation",
    "Step",
    "add_zones",
    "change_goal",
    "delete_plan",
    "fleet",
    "get_map",
    "get_plan",
    "live",
    "mapf",
    "observe",
    "passages",
    "path",
    "plan",
    "render",
    "simulate",
    "step",
    "upload_map",
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


def upload_map(fields: UploadMapFields) -> Call[MapInfo]:
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


def add_zones(map_id: str, fields: ZonesFields) -> Call[MapInfo]:
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


def get_map(map_id: str) -> Call[MapInfo]:
    return Call("GET", f"/maps/{map_id}", decode(MapInfo))


def passages(map_id: str, robot_radius: float, max_width: float | None) -> Call[Passages]:
    query = json_body({"robot_radius": robot_radius, "max_width": max_width})
    return Call("GET", f"/maps/{map_id}/passages", decode(Passages), {"params": query})


def plan(map_id: str, start: CellIn, goal: CellIn, options: RouteFields) -> Call[Plan]:
    body = json_body({"map_id": map_id, "start": start, "goal": goal, **options})
    return Call("POST", "/plan", decode(Plan), {"json": body})


def get_plan(plan_id: str) -> Call[PlanDetail]:
    return Call("GET", f"/plan/{plan_id}", decode(PlanDetail))


def path(plan_id: str, frame_id: str | None) -> Call[NavPath]:
    query = {} if frame_id is None else {"frame_id": frame_id}
    return Call("GET", f"/plan/{plan_id}/path", decode(NavPath), {"params": query})


def delete_plan(plan_id: str) -> Call[None]:
    return Call("DELETE", f"/plan/{plan_id}", lambda response: None)


def step(plan_id: str, dynamic_obstacles: Sequence[Any], fields: StepFields) -> Call[Step]:
    obstacles = [o if isinstance(o, Mapping) else as_cell(o) for o in dynamic_obstacles]
    body = {"dynamic_obstacles": obstacles, **json_body(fields)}
    return Call("POST", f"/plan/{plan_id}/step", decode(Step), {"json": body})


def simulate(map_id: str, start: CellIn, goal: CellIn, fields: SimulateFields) -> Call[Simulation]:
    body = json_body({"start": start, "goal": goal, **fields})
    return Call("POST", f"/maps/{map_id}/simulate", decode(Simulation), {"json": body})


def render(path: str, query: dict[str, Any]) -> Call[bytes]:
    """A picture (PNG bytes) at ``path``: a map's, a plan's or a map's live marks'."""
    return Call("GET", path, png, {"params": query})


def change_goal(plan_id: str, goal: CellIn) -> Call[PlanDetail]:
    body = {"goal": as_cell(goal)}
    return Call("PATCH", f"/plan/{plan_id}", decode(PlanDetail), {"json": body})


def mapf(map_id: str, agents: Sequence[tuple[CellIn, CellIn]], fields: MapfFields) -> Call[Mapf]:
    body = json_body(
        {"agents": [{"start": as_cell(s), "goal": as_cell(g)} for s, g in agents], **fields}
    )
    return Call("POST", f"/maps/{map_id}/mapf", decode(Mapf), {"json": body})


def observe(
    map_id: str, scan: Mapping[str, Any], scan_pose: Mapping[str, float], robot_radius: float
) -> Call[Observation]:
    body = {"scan": dict(scan), "scan_pose": dict(scan_pose), "robot_radius": robot_radius}
    return Call("POST", f"/maps/{map_id}/observations", decode(Observation), {"json": body})


def live(map_id: str) -> Call[LiveMarks]:
    return Call("GET", f"/maps/{map_id}/live", decode(LiveMarks))


def fleet(name: str, ahead: bool) -> Call[Fleet]:
    query = {"ahead": True} if ahead else {}
    return Call("GET", f"/fleets/{name}", decode(Fleet), {"params": query})

"""``python -m planner passages``: the narrow passages of a map for a round robot, as a table,
as JSON (the API's answer), and as a picture."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from planner.analysis.analyse import analyse_map
from planner.analysis.passages import (
    MAX_WIDTH_SLACK,
    Passage,
    crossed_passages,
    find_passages,
    path_narrowest,
)
from planner.maps.grids import read_map
from planner.maps.robot_maps import RobotMap, grid_map
from planner.maps.ros_maps import read_ros_map
from planner.params import resolve_params
from planner.plans.planning import Plan
from planner.render import render_map

__all__ = ["add_command", "crossings"]


def add_command(sub: Any) -> None:
    """Add the ``passages`` command to the command line's subparsers."""
    p = sub.add_parser(
        "passages", help="list the narrow passages of a map for a round robot (meters)"
    )
    p.add_argument("--map", type=Path, required=True, help="a ROS map .yaml (or a .map file)")
    p.add_argument("--robot-radius", type=float, required=True, metavar="M", help="meters")
    p.add_argument(
        "--max-width", type=float, metavar="M",
        help="narrow means at most this wide, meters (default 2 * radius + 0.3)",
    )  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the API's answer as JSON")
    p.add_argument("--png", type=Path, metavar="OUT.png", help="also draw them on the map")
    p.set_defaults(run=_passages)


def crossings(
    result: Plan, robot_map: RobotMap | None
) -> tuple[dict[str, Any], tuple[Passage, ...]]:
    """A plan's ``narrowest`` and crossed ``passages`` as its preview gives them over HTTP (both
    None on a plain grid: ``robot_map`` None or plain), and the passages it crosses, to draw."""
    analysis = result.analysis
    if robot_map is None or robot_map.plain or analysis.cspace is None:
        return {"narrowest": None, "passages": None}, ()
    found = find_passages(robot_map, result.params.robot_radius)
    ids = crossed_passages(found, result.path, robot_map.shape)
    x, y, width = path_narrowest(analysis.cspace, analysis.frame, result.path)
    narrowest = {"x": round(x, 6), "y": round(y, 6), "width_m": round(width, 6)}
    return {"narrowest": narrowest, "passages": list(ids)}, tuple(found[i] for i in set(ids))


def _read(path: Path) -> RobotMap:
    if path.suffix.lower() in (".yaml", ".yml"):
        return read_ros_map(path)
    return grid_map(read_map(path))  # a Moving AI map: 1 m a cell


def _passages(args: argparse.Namespace) -> int:
    robot_map = _read(args.map)
    found = find_passages(robot_map, args.robot_radius, args.max_width)
    widest = args.max_width
    if widest is None:
        widest = 2 * args.robot_radius + MAX_WIDTH_SLACK
    if args.json:
        rows = [
            {"id": p.id, "x": round(p.x, 6), "y": round(p.y, 6),
             "width_m": round(p.width_m, 6), "length_m": round(p.length_m, 6)}
            for p in found
        ]  # fmt: skip
        answer = {"passages": rows, "robot_radius": args.robot_radius, "max_width": widest}
        print(json.dumps(answer))
    else:
        print(
            f"{args.map.name}: {len(found)} narrow passage(s) for a robot of radius "
            f"{args.robot_radius:g} m (at most {widest:g} m wide)"
        )
        if found:
            print(f"{'id':>4} {'x':>9} {'y':>9} {'width_m':>8} {'length_m':>9}")
        for p in found:
            print(f"{p.id:>4} {p.x:>9.3f} {p.y:>9.3f} {p.width_m:>8.3f} {p.length_m:>9.3f}")
    if args.png is not None:
        analysis = analyse_map(robot_map, resolve_params(robot_radius=args.robot_radius))
        args.png.write_bytes(render_map(analysis, passages=found))
        print(f"wrote {args.png}", file=sys.stderr)
    return 0

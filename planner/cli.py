"""``python -m planner``: plan, run Moving AI scenarios, simulate, run the paper's experiment,
render pictures, list a map's narrow passages, solve a MAPF instance, or show the bundled demo."""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from planner.analysis.analyse import analyse
from planner.cli_experiment import add_experiment_command
from planner.cli_mapf import add_mapf_command
from planner.cli_passages import add_command, crossings
from planner.errors import InvalidInput, PlannerError
from planner.experiment.environments import environment
from planner.experiment.runs import DYNAMIC
from planner.maps.grids import read_map, read_scen
from planner.maps.robot_maps import RobotMap
from planner.maps.ros_maps import read_ros_map
from planner.params import PRESETS, resolve_params
from planner.plans.planning import Plan, plan
from planner.poses.nav import nav_msgs_path
from planner.render import render_episode, render_plan
from planner.stepping.simulation import run_episode, simulate, warm_up

T = TypeVar("T", int, float)

__all__ = ["main"]

EXAMPLE_MAP = resources.files("planner") / "data" / "example.map"
EXAMPLE_START = (7, 2)
EXAMPLE_GOAL = (7, 26)
TOLERANCE = 1e-3


def main(argv: Sequence[str] | None = None) -> int:
    """The command line, as ``python -m planner`` or the ``planner`` console script runs it."""
    # The console script is named in its usage line; everything else prints the same.
    prog = "planner" if Path(sys.argv[0]).name == "planner" else "python -m planner"
    parser = _parser(prog)
    args = parser.parse_args(_negative_points(sys.argv[1:] if argv is None else argv))
    warm_up()  # so that the times reported are the planner's, not numba's compiler's
    try:
        result: int = args.run(args)
    except PlannerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return result


def _negative_points(argv: Sequence[str]) -> list[str]:
    """``--start -12.5,22.0`` as ``--start=-12.5,22.0``, which argparse takes for no option."""
    out: list[str] = []
    for word in argv:
        if out and out[-1] in ("--start", "--goal") and re.match(r"-\.?\d", word):
            out[-1] += f"={word}"
        else:
            out.append(word)
    return out


def _parser(prog: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__)
    sub = parser.add_subparsers(required=True, metavar="COMMAND")

    demo = sub.add_parser("demo", help="plan on the bundled example map and explain the result")
    demo.set_defaults(run=_demo)

    p = sub.add_parser(
        "plan",
        help="plan on a Moving AI .map file (cells R C) or a ROS map .yaml (points X,Y in meters)",
    )
    p.add_argument("map", nargs="?", type=Path, help="a Moving AI .map file (or use --map)")
    p.add_argument("--map", dest="map_option", type=Path, help="a .map file or a ROS map .yaml")
    p.add_argument("--start", nargs="+", required=True, metavar="R C | X,Y[,YAW]")
    p.add_argument("--goal", nargs="+", required=True, metavar="R C | X,Y[,YAW]")
    p.add_argument("--preset", default="wide", choices=sorted(PRESETS))
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--robot-radius", type=float, help="the robot's radius in meters (ROS maps)")
    p.add_argument("--unknown", choices=["blocked", "free"], help="how unknown space counts")
    p.add_argument(
        "--footprint", metavar="JSON", help='the robot\'s polygon in its frame, meters, in place '
        'of --robot-radius (ROS maps): "[[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]]"',
    )  # fmt: skip
    p.add_argument("--motion", choices=["diff", "car", "car_reverse"], help="how it turns")
    p.add_argument("--min-turning-radius", type=float, metavar="M", help="a car's, in meters")
    p.add_argument(
        "--goal-tolerance", type=float, default=0.0, metavar="M",
        help="meters: plan to the nearest reachable cell within M when the goal cannot be used",
    )  # fmt: skip
    p.add_argument(
        "--json", action="store_true", help="print the plan's preview as JSON (with its poses)"
    )
    p.add_argument(
        "--format", choices=["text", "json", "nav_msgs"], default=None,
        help="what to print: a line of text (ROS maps) or the summary (.map files), the "
        "preview as JSON (--json), or the poses as a rosbridge nav_msgs/Path",
    )  # fmt: skip
    p.add_argument("--frame-id", default="map", help="the nav_msgs/Path's frame_id (map)")
    p.add_argument("--png", type=Path, metavar="OUT.png", help="also draw the plan")
    p.set_defaults(run=_plan)

    s = sub.add_parser("scen", help="run a Moving AI .scen file; print a JSON summary line")
    s.add_argument("scen", type=Path, help="the .scen file")
    s.add_argument("--map", type=Path, help="the .map file (default: the one named, beside it)")
    s.add_argument("--preset", default="shortest", choices=sorted(PRESETS))
    s.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    s.add_argument("--limit", type=int, help="run N lines, evenly spread over the file")
    s.set_defaults(run=_scen)

    m = sub.add_parser("simulate", help="run one seeded episode among moving obstacles")
    _map_args(m)
    m.add_argument("--dynamic-count", type=int, default=10, help="number of dynamic obstacles")
    m.add_argument("--seed", type=int, default=0)
    m.add_argument("--max-steps", type=int)
    m.add_argument(
        "--obstacle-motion", choices=["turns", "simultaneous"], default="turns",
        help="obstacles move before the robot decides (turns) or while it moves (simultaneous)",
    )  # fmt: skip
    m.set_defaults(run=_simulate)

    add_experiment_command(sub)

    r = sub.add_parser("render", help="draw a map, its analysis and a plan as PNG (and a GIF)")
    r.add_argument(
        "map",
        help="a Moving AI .map file, a ROS map_server .yaml (its known part drawn, with axes in "
        "meters), or envN[:SEED] for generated environment N",
    )
    r.add_argument("--start", type=int, nargs=2, required=True, metavar=("R", "C"))
    r.add_argument("--goal", type=int, nargs=2, required=True, metavar=("R", "C"))
    r.add_argument("--preset", default="wide", choices=sorted(PRESETS))
    r.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    r.add_argument("--out", type=Path, required=True, help="the PNG file to write")
    r.add_argument("--field", choices=["clean", "kw"], help="heat map under the free cells")
    r.add_argument(
        "--cell", type=int, help="pixels per map cell (default: a legible size, up to 24)"
    )
    r.add_argument("--animate", type=Path, metavar="FILE.gif", help="also write an episode GIF")
    r.add_argument(
        "--dynamic-count", type=int, default=DYNAMIC, help="dynamic obstacles (--animate)"
    )
    r.add_argument("--seed", type=int, default=0, help="the episode's seed (--animate)")
    r.set_defaults(run=_render)
    add_command(sub)
    add_mapf_command(sub)
    return parser


def _map_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("map", type=Path, help="a Moving AI .map file")
    p.add_argument("--start", type=int, nargs=2, required=True, metavar=("R", "C"))
    p.add_argument("--goal", type=int, nargs=2, required=True, metavar=("R", "C"))
    p.add_argument("--preset", default="wide", choices=sorted(PRESETS))
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")


def _params(pairs: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for pair in pairs:
        name, sep, text = pair.partition("=")
        if not sep:
            raise SystemExit(f"--param takes NAME=VALUE; got {pair!r}")
        try:
            out[name] = json.loads(text)
        except json.JSONDecodeError:
            out[name] = text
    return out


PREVIEW_KEYS = (
    "path", "path_xy", "length", "length_m", "arc_cost", "min_clearance", "min_clearance_m",
    "mean_clearance", "mean_clearance_m", "contact_ratio", "length_poses_m", "goal_offset_m",
)  # fmt: skip


def _json_arg(text: str, name: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        msg = f"--{name} must be JSON, such as [[0.3, 0.2], [0.3, -0.2], [-0.3, 0]]; got {text!r}"
        raise InvalidInput(msg, field=name) from exc


def _preview(summary: dict[str, Any]) -> dict[str, Any]:
    """The API's ``preview`` object: poses as ``{x, y, yaw}`` (with ``direction`` for a
    footprint or a car), ``goal_used`` as ``{x, y}``."""
    used = summary["goal_used"]
    directions = summary["directions"] or [None] * len(summary["poses"])
    poses = [{"x": x, "y": y, "yaw": yaw} for x, y, yaw in summary["poses"]]
    for pose, d in zip(poses, directions, strict=True):
        if d is not None:
            pose["direction"] = d
    return {
        **{key: summary[key] for key in PREVIEW_KEYS},
        "poses": poses,
        "goal_used": None if used is None else {"x": used[0], "y": used[1]},
    }


def _plan(args: argparse.Namespace) -> int:
    path = args.map_option or args.map
    if path is None:
        raise InvalidInput("plan needs a map: a .map file or --map FILE.yaml", field="map")
    params = _params(args.param)
    if args.robot_radius is not None:
        params["robot_radius"] = args.robot_radius
    if args.unknown is not None:
        params["unknown"] = args.unknown
    if args.footprint is not None:
        params["footprint"] = _json_arg(args.footprint, "footprint")
    if args.motion is not None:
        params["motion"] = args.motion
    if args.min_turning_radius is not None:
        params["min_turning_radius"] = args.min_turning_radius
    form = args.format or ("json" if args.json else "text")
    tolerance = args.goal_tolerance
    robot_map = None
    if Path(path).suffix.lower() not in (".yaml", ".yml"):
        cells = _cell_arg(args.start, "start"), _cell_arg(args.goal, "goal")
        result = plan(
            read_map(path), *cells, preset=args.preset, goal_tolerance=tolerance, **params
        )
        if form == "text":
            print(json.dumps(result.summary()))
    else:
        robot_map = read_ros_map(path)
        points = _point_arg(args.start, "start"), _point_arg(args.goal, "goal")
        result = plan(robot_map, *points, preset=args.preset, goal_tolerance=tolerance, **params)
        if form == "text":
            print(
                f"{args.preset}: {len(result.path) - 1} moves, length {result.length_m:.2f} m "
                f"(poses {result.length_poses_m:.2f} m), clearance min "
                f"{result.min_clearance_m:.2f} m, mean {result.mean_clearance_m:.2f} m (robot "
                f"radius {result.params.robot_radius:g} m), narrow fallback: "
                f"{result.narrow_fallback}"
                + (f", goal moved {result.goal_offset_m:.3f} m" if result.goal_used else "")
            )
    if form == "json":  # the API's preview object
        print(json.dumps({**_preview(result.summary()), **crossings(result, robot_map)[0]}))
    elif form == "nav_msgs":
        print(json.dumps(nav_msgs_path(result.poses, args.frame_id, time.time())))
    if args.png is not None:
        drawn = render_plan(result, passages=crossings(result, robot_map)[1], crop=True)
        args.png.write_bytes(drawn)
        print(f"wrote {args.png}", file=sys.stderr)
    return 0


def _two(values: list[str], name: str, number: Callable[[str], T], what: str) -> tuple[T, T]:
    """Two numbers given as two words or ``A,B``, else InvalidInput saying what ``--name`` takes."""
    parts = [p for v in values for p in v.split(",") if p]
    try:
        a, b = (number(p) for p in parts)
    except ValueError:
        msg = f"--{name} takes {what}; got {' '.join(values)!r}"
        raise InvalidInput(msg, field=name) from None
    return a, b


def _cell_arg(values: list[str], name: str) -> tuple[int, int]:
    return _two(values, name, int, "a cell R C (two integers) on a .map file")


def _point_arg(values: list[str], name: str) -> dict[str, float]:
    parts = [p for v in values for p in v.split(",") if p]
    if len(parts) == 3:  # X,Y,YAW: a heading too (radians)
        x, y = _two(parts[:2], name, float, "a point X,Y[,YAW] in meters (radians) on a ROS map")
        yaw = _two([parts[2], "0"], name, float, "a point X,Y[,YAW] in meters on a ROS map")[0]
        return {"x": x, "y": y, "yaw": yaw}
    x, y = _two(values, name, float, "a point X,Y[,YAW] in meters (radians) on a ROS map")
    return {"x": x, "y": y}


def _simulate(args: argparse.Namespace) -> int:
    episode = simulate(
        read_map(args.map),
        args.start,
        args.goal,
        preset=args.preset,
        dynamic_count=args.dynamic_count,
        seed=args.seed,
        max_steps=args.max_steps,
        obstacle_motion=args.obstacle_motion,
        **_params(args.param),
    )
    print(json.dumps({**episode.metrics, "obstacle_motion": episode.obstacle_motion}))
    return 0


def _scen(args: argparse.Namespace) -> int:
    lines = read_scen(args.scen)
    if not lines:
        raise SystemExit(f"{args.scen} holds no scenario lines")
    if args.limit is not None and args.limit < len(lines):
        picks = np.linspace(0, len(lines) - 1, max(args.limit, 1)).round().astype(int)
        lines = [lines[i] for i in sorted(set(picks.tolist()))]
    map_path = args.map or args.scen.parent / Path(lines[0].map_name).name
    grid = read_map(map_path)
    p = resolve_params(args.preset, **_params(args.param))
    analysis = analyse(
        grid, seal_tunnels=p.seal_tunnels, clean_weight=p.clean_weight, clean_radius=p.clean_radius
    )
    solved = mismatches = 0
    max_err = 0.0
    total = 0.0
    for line in lines:
        t0 = time.perf_counter()
        try:
            result: Plan | None = plan(
                None,
                line.start,
                line.goal,
                preset=args.preset,
                analysis=analysis,
                **_params(args.param),
            )
        except PlannerError:
            result = None
        total += time.perf_counter() - t0
        if result is None:
            mismatches += 1
            max_err = float("inf")
            continue
        solved += 1
        err = abs(result.length - line.optimal)
        max_err = max(max_err, err)
        mismatches += err > TOLERANCE
    summary = {
        "scen": str(args.scen),
        "map": str(map_path),
        "preset": args.preset,
        "lines": len(lines),
        "solved": solved,
        "mismatches": mismatches,
        "max_abs_error": max_err if max_err != float("inf") else None,
        "mean_ms": round(total / len(lines) * 1e3, 3),
    }
    print(json.dumps(summary))
    return 1 if mismatches and args.preset == "shortest" else 0


def _render(args: argparse.Namespace) -> int:
    grid = _map_or_environment(args.map)
    result = plan(grid, args.start, args.goal, preset=args.preset, **_params(args.param))
    args.out.write_bytes(render_plan(result, field=args.field, cell=args.cell, crop=True))
    print(f"wrote {args.out}")
    if args.animate is not None:
        episode = run_episode(result, dynamic_count=args.dynamic_count, seed=args.seed)
        args.animate.write_bytes(render_episode(episode, cell=args.cell))
        print(f"wrote {args.animate}: {json.dumps(episode.metrics)}")
    return 0


def _map_or_environment(text: str) -> np.ndarray | RobotMap:
    name, _, seed = text.partition(":")
    if name.startswith("env") and name[3:].isdigit() and (not seed or seed.isdigit()):
        return environment(int(name[3:]), seed=int(seed or 0))
    if text.endswith((".yaml", ".yml")):
        return read_ros_map(text)
    return read_map(text)


def _demo(args: argparse.Namespace) -> int:
    grid = read_map(Path(str(EXAMPLE_MAP)))
    wide = plan(grid, EXAMPLE_START, EXAMPLE_GOAL, preset="wide")
    short = plan(grid, EXAMPLE_START, EXAMPLE_GOAL, preset="shortest")
    print(
        f"The bundled example map ({grid.shape[0]} x {grid.shape[1]}), "
        f"start S {EXAMPLE_START}, goal G {EXAMPLE_GOAL}."
    )
    print("'#' obstacle, '~' tight-tunnel cell (sealed by `wide`), '*' the `wide` path,")
    print("'+' the `shortest` path, 'x' both.\n")
    print(_ascii(grid, wide, short))
    print()
    for name, p in (("wide", wide), ("shortest", short)):
        print(
            f"{name:>8}: length {p.length:6.2f}, moves {len(p.path) - 1:3d}, "
            f"min clearance {p.min_clearance:.2f}, mean clearance {p.mean_clearance:.2f}, "
            f"touching obstacles on {p.contact_ratio:.0%} of its cells"
        )
    print(
        f"\nThe analysis found {wide.tunnels} tight-tunnel cells and {wide.gates} gates. "
        "`shortest` slips through the one-cell corridor;\n`wide` seals it and crosses the open "
        f"room instead, {wide.length / short.length - 1:.0%} longer, keeping away from walls."
    )
    print("\nTry: .venv/bin/planner plan MAP --start R C --goal R C (see docs/python.md).")
    return 0


def _ascii(grid: np.ndarray, wide: Plan, short: Plan) -> str:
    chars = np.where(grid == 1, "#", ".").astype("<U1")
    chars[wide.analysis.state == 2] = "~"
    on_wide = np.zeros(grid.shape, dtype=bool)
    on_wide[wide.path[:, 0], wide.path[:, 1]] = True
    on_short = np.zeros(grid.shape, dtype=bool)
    on_short[short.path[:, 0], short.path[:, 1]] = True
    chars[on_wide] = "*"
    chars[on_short] = "+"
    chars[on_wide & on_short] = "x"
    chars[wide.start] = "S"
    chars[wide.goal] = "G"
    return "\n".join("".join(row) for row in chars)

"""Wide-free-space path planning on 2D occupancy grids.

The improved MAX-MIN Ant System planner of Hasan, Abdullah & Saleh (2023), read precisely as
``docs/algorithm.md`` says: map analysis (gates, tight tunnels, the ``clean`` penalty), a goal wave
(cost-to-go fields ``k`` and ``kw``, over the whole map or settled on demand), the paper's move
decision (Eq. 3) and the loop-free ``wide`` decision, stepping among dynamic obstacles, the
paper's simulated experiment on its six environments, and pictures like its figures. Robot maps
in meters (ROS ``map_server`` YAML + image, ``nav_msgs/OccupancyGrid``) are planned for a round
robot over its configuration space.

>>> import planner
>>> p = planner.plan([[0, 0, 0], [1, 1, 0], [0, 0, 0]], [0, 0], [2, 0], preset="shortest")
>>> p.path.tolist()
[[0, 0], [0, 1], [0, 2], [1, 2], [2, 2], [2, 1], [2, 0]]
"""

from planner.analysis.analyse import (
    Analysis,
    analyse,
    analyse_map,
    analysis_key,
    analysis_params,
    params_key,
    resolve_wall_cost,
)
from planner.analysis.cspace import CSpace, circle_cells, configuration_space, wide_clean
from planner.analysis.passages import Passage, crossed_passages, find_passages, path_narrowest
from planner.analysis.rezone import rezone_analysis
from planner.errors import (
    QUOTE_LIMIT,
    InvalidInput,
    NoValidPath,
    PlannerError,
    SequenceConflict,
    quote,
)
from planner.experiment.environments import TABLE1, environment
from planner.experiment.runs import compare, run_experiment
from planner.footprint import Footprint, footprint_of
from planner.live.scans import LaserScan, Traced, trace_scan
from planner.maps.frames import MapFrame
from planner.maps.grids import (
    Scenario,
    as_grid,
    format_map,
    parse_map,
    parse_rows,
    read_map,
    read_scen,
)
from planner.maps.robot_maps import RobotMap, grid_map, occupancy_grid_map
from planner.maps.ros_maps import (
    MapYaml,
    decode_map_image,
    image_size,
    parse_map_yaml,
    parse_ros_map,
    read_ros_map,
)
from planner.maps.zones import KeepoutMask, SpeedZone, Zones, speed_limits
from planner.maps.zoning import keepout_mask, zone_map
from planner.motion import MotionPath, Robot, drive, dubins, reeds_shepp
from planner.params import PRESETS, Params, resolve_params
from planner.plans.planning import Plan, clearance_metrics, plan
from planner.plans.reach import reaches
from planner.plans.resumable_wave import ResumableWave, Unsettled, resumable_wave
from planner.plans.route import MAX_WAYPOINTS, Route, route_of
from planner.plans.whole_wave import Wave, WaveView, goal_wave
from planner.poses import nav_msgs_path, smooth_path
from planner.poses.speed import profile_time
from planner.render import render_episode, render_map, render_plan
from planner.render_live import render_live
from planner.stepping.replan import detour
from planner.stepping.session import MOVES, Session, SessionState, Step
from planner.stepping.simulation import Episode, ObstacleMotion, run_episode, simulate, warm_up

__all__ = [
    "MAX_WAYPOINTS",
    "MOVES",
    "PRESETS",
    "QUOTE_LIMIT",
    "TABLE1",
    "Analysis",
    "CSpace",
    "Episode",
    "Footprint",
    "InvalidInput",
    "KeepoutMask",
    "LaserScan",
    "MapFrame",
    "MapYaml",
    "MotionPath",
    "NoValidPath",
    "ObstacleMotion",
    "Params",
    "Passage",
    "Plan",
    "PlannerError",
    "ResumableWave",
    "Robot",
    "RobotMap",
    "Route",
    "Scenario",
    "SequenceConflict",
    "Session",
    "SessionState",
    "SpeedZone",
    "Step",
    "Traced",
    "Unsettled",
    "Wave",
    "WaveView",
    "Zones",
    "analyse",
    "analyse_map",
    "analysis_key",
    "analysis_params",
    "as_grid",
    "circle_cells",
    "clearance_metrics",
    "compare",
    "configuration_space",
    "crossed_passages",
    "decode_map_image",
    "detour",
    "drive",
    "dubins",
    "environment",
    "find_passages",
    "footprint_of",
    "format_map",
    "goal_wave",
    "grid_map",
    "image_size",
    "keepout_mask",
    "nav_msgs_path",
    "occupancy_grid_map",
    "params_key",
    "parse_map",
    "parse_map_yaml",
    "parse_ros_map",
    "parse_rows",
    "path_narrowest",
    "plan",
    "profile_time",
    "quote",
    "reaches",
    "read_map",
    "read_ros_map",
    "read_scen",
    "reeds_shepp",
    "render_episode",
    "render_live",
    "render_map",
    "render_plan",
    "resolve_params",
    "resolve_wall_cost",
    "resumable_wave",
    "rezone_analysis",
    "route_of",
    "run_episode",
    "run_experiment",
    "simulate",
    "smooth_path",
    "speed_limits",
    "trace_scan",
    "warm_up",
    "wide_clean",
    "zone_map",
]

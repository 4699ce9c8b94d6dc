"""The examples of the API's documentation (``/docs``): one small map and a plan on it, so that
the examples chain (the map's real ``map_id``; a test checks it)."""

from __future__ import annotations

from typing import Any

__all__ = ["EXAMPLE_MAP", "EXAMPLE_MAP_ID", "EXAMPLE_PLAN", "EXAMPLE_TRAJECTORY_METRICS"]

EXAMPLE_MAP: dict[str, Any] = {
    "rows": ["......", "......", "..@@..", "......", "......"],
    "start": [0, 0],
    "goal": [4, 5],
}
"""The map of every example: a 5 x 6 room with a 2-cell block in the middle."""

EXAMPLE_MAP_ID = "2f68cb9d10f4ad46475d5a3851711826daff07c5d2a4479cee604bc39e2872ca"
"""``EXAMPLE_MAP``'s real ``map_id`` (a test checks it), so that the examples chain."""

EXAMPLE_PLAN: dict[str, Any] = {
    "plan_id": "9f1c2a7be04d4f65a3c8e2b17d90c5aa",
    "map_id": EXAMPLE_MAP_ID,
    "name": None,
    "start": [0, 0],
    "goal": [4, 5],
    "preset": "wide",
    "params": {
        "decision": "wide",
        "seal_tunnels": True,
        "clean_weight": 0.5,
        "clean_radius": 2,
        "diagonal_cost": 1.4142135623730951,
        "alpha": 3.0,
        "beta": 1.0,
        "patience": 3,
        "allow_narrow": True,
        "robot_radius": 0.0,
        "unknown": "blocked",
        "occupied_threshold": 65,
        "wall_cost": "auto",
        "wide_weight": 80.0,
        "wide_distance": 0.6,
        "dynamic_margin": 1,
        "dynamic_margin_m": None,
        "horizon_m": 2.0,
        "deviation_m": 0.5,
        "nominal_speed": 0.5,
        "max_detour": 1.3,
        "footprint": None,
        "motion": "diff",
        "min_turning_radius": None,
        "max_velocity": None,
        "max_acceleration": None,
        "max_angular_velocity": None,
    },
    "status": "ready",
    "position": [0, 0],
    "narrow_fallback": False,
    "analysis": {"gates": 0, "tunnels": 0, "narrow_fallback": False, "cache_hit": False,
                 "analysis_ms": 0.02},
    "preview": {
        "path": [[0, 0], [1, 1], [1, 2], [1, 3], [1, 4], [2, 4], [3, 4], [4, 5]],
        "length": 7.828427,
        "arc_cost": 23.485281,
        "min_clearance": 1.0,
        "mean_clearance": 1.1553,
        "contact_ratio": 1.0,
        "path_xy": [[0.5, 4.5], [1.5, 3.5], [2.5, 3.5], [3.5, 3.5], [4.5, 3.5], [4.5, 2.5],
                    [4.5, 1.5], [5.5, 0.5]],
        "length_m": 7.828427,
        "min_clearance_m": 1.0,
        "mean_clearance_m": 1.15533,
        "poses": [
            {"x": 0.5, "y": 4.5, "yaw": -0.24497866312686414},
            {"x": 1.2114673406298062, "y": 4.3221331648425485, "yaw": -0.24497866312686414},
            {"x": 1.9229346812596124, "y": 4.144266329685097, "yaw": -0.24497866312686414},
            {"x": 2.8357593872696345, "y": 3.815824929280116, "yaw": -0.4457920849811421},
            {"x": 3.6647275152506698, "y": 3.3119057490598283, "yaw": -0.6466055068354201},
            {"x": 4.3765222585980705, "y": 2.652761651957171, "yaw": -0.8474189286896981},
            {"x": 4.942536090670168, "y": 1.8648840984595938, "yaw": -1.0482323505439761},
            {"x": 5.340020521214833, "y": 0.9799384363555004, "yaw": -1.2490457723982544},
            {"x": 5.5, "y": 0.5, "yaw": -1.2490457723982544},
        ],
        "length_poses_m": 6.823201,
        "duration_s": 13.646402,
        "goal_used": None,
        "goal_offset_m": 0.0,
        "waypoint_indices": [],
        "detour": {"shortest_m": 7.828427, "ratio": 1.0, "width_kept": 1.0,
                   "tunnels_opened": False},
    },
    "waypoints": [],
}  # fmt: skip
EXAMPLE_PLAN["position_xy"] = [0.5, 4.5]

EXAMPLE_TRAJECTORY_METRICS: dict[str, Any] = {
    "iterations": 1,
    "moves": 1,
    "waits": 0,
    "replans": 0,
    "path_length": 1.0,
    "arc_cost": 6.828427,
    "min_clearance": 1.0,
    "mean_clearance": 1.0,
    "contact_ratio": 1.0,
    "length_m": 1.0,
    "min_clearance_m": 1.0,
    "mean_clearance_m": 1.0,
}

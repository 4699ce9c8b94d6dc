"""Fleets: robots of one map stepping among each other (docs/fleets.md)."""

from planner.fleets.robots import Robot, covering, robot_cells
from planner.fleets.traffic import NO_TRAFFIC, YIELD_STEPS, Traffic, after_step, traffic_for
from planner.fleets.waiting import WaitingZones, no_waiting_zones, wait_distance, waiting_zones

__all__ = [
    "NO_TRAFFIC",
    "YIELD_STEPS",
    "Robot",
    "Traffic",
    "WaitingZones",
    "after_step",
    "covering",
    "no_waiting_zones",
    "robot_cells",
    "traffic_for",
    "wait_distance",
    "waiting_zones",
]

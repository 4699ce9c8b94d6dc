"""Fleets: robots of one map stepping among each other (docs/fleets.md)."""

from planner.fleets.robots import Robot, covering, disk_offsets, robot_cells
from planner.fleets.traffic import Traffic, after_step, traffic_for
from planner.fleets.zones import Zones, no_zones, passage_zones, wait_distance

__all__ = [
    "Robot",
    "Traffic",
    "Zones",
    "after_step",
    "covering",
    "disk_offsets",
    "no_zones",
    "passage_zones",
    "robot_cells",
    "traffic_for",
    "wait_distance",
]

"""Robot shapes and motion: a footprint's collision checks per heading bin, Reeds-Shepp and
Dubins curves, the hybrid search in (x, y, heading) for ``diff``, ``car`` and ``car_reverse``
motions, shortening that keeps clearance, and the time to drive a path (docs/shapes.md)."""

from planner.motion.collide import (
    Grid,
    densify,
    footprint_clearance,
    grid_of,
    motions_free,
    poses_free,
)
from planner.motion.curves import Curve, dubins, reeds_shepp
from planner.motion.hybrid import MotionPath, Robot, drive

__all__ = [
    "Curve",
    "Grid",
    "MotionPath",
    "Robot",
    "densify",
    "drive",
    "dubins",
    "footprint_clearance",
    "grid_of",
    "motions_free",
    "poses_free",
    "reeds_shepp",
]

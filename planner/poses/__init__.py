"""Poses a robot controller can follow: the grid path made smooth, with a heading on every pose."""

from planner.poses.nav import nav_msgs_path
from planner.poses.smooth import smooth_path

__all__ = ["nav_msgs_path", "smooth_path"]

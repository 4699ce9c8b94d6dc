"""Poses a robot controller can follow: the grid path made smooth, with a heading on every pose."""

from planner.poses.smooth import smooth_path

__all__ = ["smooth_path"]

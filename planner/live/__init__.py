"""What the robots see: laser scans traced on a map into the cells they mark and clear, the
live layer every plan on the map shares (docs/live.md)."""

from planner.live.scans import MAX_RAYS, LaserScan, Traced, trace_rays, trace_scan

__all__ = ["MAX_RAYS", "LaserScan", "Traced", "trace_rays", "trace_scan"]

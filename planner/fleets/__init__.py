"""Fleets (docs/fleets.md): robots of one map planned together. Three stages: the roadmap over
the map's configuration space, the MAPF solver (LaCAM with PIBT) on it, and the execution of its
joint plan by an action dependency graph."""

from planner.fleets.execution import Move, Schedule, schedule, segment_distances, timed_moves
from planner.fleets.graph import Graph, grid_graph

__all__ = [
    "Graph",
    "Move",
    "Schedule",
    "grid_graph",
    "schedule",
    "segment_distances",
    "timed_moves",
]

"""Fleets (docs/fleets.md): robots of one map planned together. Three stages: the roadmap over
the map's configuration space, the MAPF solver (LaCAM with PIBT) on it, and the execution of its
joint plan by an action dependency graph."""

from planner.fleets.execution import Move, Schedule, schedule, segment_distances, timed_moves
from planner.fleets.graph import Graph, grid_graph
from planner.fleets.mapf import Solution, solve
from planner.fleets.roadmap import attach, attach_all, build_roadmap

__all__ = [
    "Graph",
    "Move",
    "Schedule",
    "Solution",
    "attach",
    "attach_all",
    "build_roadmap",
    "grid_graph",
    "schedule",
    "segment_distances",
    "solve",
    "timed_moves",
]

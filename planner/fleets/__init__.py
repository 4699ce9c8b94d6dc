"""Fleets: robots of one map planned together (docs/api.md, "Fleets"): the graph they move on,
and offline multi-agent path finding on it (LaCAM with PIBT)."""

from planner.fleets.graph import Graph, grid_graph
from planner.fleets.mapf import Solution, solve

__all__ = ["Graph", "Solution", "grid_graph", "solve"]

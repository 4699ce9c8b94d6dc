"""The bound on a MAPF solve's size: agents times roadmap nodes (its distance tables)."""

from __future__ import annotations

import planner
from planner.fleets import Graph

__all__ = ["MAX_TABLE_ENTRIES", "check_size"]

MAX_TABLE_ENTRIES = 20_000_000
"""Agents times roadmap nodes at most: the solver keeps a distance table of each agent's goal
over every node (8 bytes an entry, twice), so this bounds a solve's memory to about 320 MB."""


def check_size(agents: int, graph: Graph, field: str) -> None:
    """``InvalidInput`` naming ``field`` when ``agents`` on ``graph`` exceed the table bound."""
    if agents * graph.nodes > MAX_TABLE_ENTRIES:
        most = MAX_TABLE_ENTRIES // max(graph.nodes, 1)
        msg = (
            f"{agents} agents on a roadmap of {graph.nodes} nodes: at most {most} here "
            f"(agents x nodes <= {MAX_TABLE_ENTRIES})"
        )
        raise planner.InvalidInput(msg, field=field)

"""A fleet solved again from where its robots are (docs/fleets.md): the joint plan's inputs
from the fleet's record, the planner's MAPF solver on the roadmap, and each robot's moves in
the record. Runs in the worker pool: the record in, the new record out, nothing else touched."""

from __future__ import annotations

import secrets
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

import planner
from planner.fleets import Graph, Move, attach, segment_distances, solve, timed_moves
from service.stores.base import FleetRecord

__all__ = ["FleetMap", "chain", "node_cell", "resolve"]


@dataclass(frozen=True, slots=True)
class FleetMap:
    """A fleet's roadmap, the analysis it was built on (for its robots' radius), and which
    piece of the roadmap each node is in (``pieces``: robots move within one)."""

    graph: Graph
    analysis: planner.Analysis
    pieces: npt.NDArray[np.int64]


def chain(robot: dict[str, Any]) -> list[int]:
    """The nodes a robot may be on now: the source of its first move not done, then every move
    it was told since (one node when it stands still)."""
    moves, done, told = robot["moves"], robot["done"], robot["told"]
    if not moves:
        return [robot["node"]]
    if done >= len(moves):
        return [moves[-1][1]]
    return [moves[done][0]] + [moves[k][1] for k in range(done, told)]


def resolve(
    fleet: FleetRecord, fleet_map: FleetMap, *, time_limit_s: float, seed: int
) -> FleetRecord:
    """The fleet with a new joint plan for its robots that step (the parked ones stand where
    they are, as obstacles), or, when the solver fails within its budget, its old plan kept
    with the failure in ``solve``."""
    graph = fleet_map.graph
    robots = dict(fleet["robots"])  # its own: a failed solve hands the fleet back unchanged
    extras: list[list[int]] = []
    order = sorted(robots, key=lambda k: robots[k]["rank"])
    agents = [k for k in order if not robots[k].get("parked")]
    blocked = np.zeros(graph.nodes, dtype=bool)
    for node in fleet.get("blocked", {}):
        if int(node) < graph.nodes:
            blocked[int(node)] = True
    old_extras = fleet.get("extras", [])
    reach = 2.0 * float(fleet["radius"]) / graph.resolution
    for k in order:
        if robots[k].get("parked"):
            for node in chain(robots[k]):
                if 0 <= node < graph.nodes:
                    blocked[node] = True
                else:  # standing off the roadmap: the nodes near it are its too
                    cell = np.array(node_cell(node, robots[k], old_extras, graph), dtype=np.float64)
                    near = np.linalg.norm(graph.cells - cell, axis=1) < reach
                    blocked |= near

    def others(k: str) -> list[npt.NDArray[np.float64]]:
        """The other robots' places: their chains' points, and the moves joining so far."""
        out = [
            np.array([node_cell(n, robots[o], old_extras, graph) for n in chain(robots[o])], float)
            for o in order
            if o != k
        ]
        return out + spurs

    spurs: list[npt.NDArray[np.float64]] = []
    pending: list[list[int]] = []
    starts: list[int] = []
    joins: list[int] = []  # the agents joining the roadmap from a place off it
    taken = {n for n in (chain(robots[k])[-1] for k in agents) if 0 <= n < graph.nodes}
    for k in agents:
        nodes = chain(robots[k])
        # Places off the roadmap get node numbers after the roadmap's (the schedule's points).
        nodes = [_renumber(n, robots[k], old_extras, graph, extras) for n in nodes]
        last = nodes[-1]
        if last >= graph.nodes:
            at = extras[last - graph.nodes]
            goal = int(robots[k]["goal_node"])
            joined = _join(fleet_map, at, goal, taken, others(k), reach)
            if joined < 0:
                return _failed(fleet, "unreachable", f"robot {k} has no roadmap node in reach")
            nodes.append(joined)
            spurs.append(np.array([extras[last - graph.nodes], graph.cells[joined]], float))
            last = joined
            joins.append(len(starts))
        taken.add(last)
        starts.append(last)
        pending.append(nodes)
    goals = [int(robots[k]["goal_node"]) for k in agents]
    for node in starts:
        blocked[node] = False
    for k, goal in zip(agents, goals, strict=True):
        if blocked[goal]:
            why = f"robot {k}'s goal is taken by a robot standing there or by obstacles"
            return _failed(fleet, "unsolvable", why)
    started = time.perf_counter()
    solution = solve(graph, starts, goals, time_limit_s=time_limit_s, seed=seed, blocked=blocked)
    figures = {
        "status": solution.status,
        "agents": len(agents),
        "solve_ms": round((time.perf_counter() - started) * 1000.0, 3),
        "sum_of_costs": int(solution.sum_of_costs),
        "lower_bound": int(solution.lower_bound),
        "makespan": int(solution.makespan),
        "at": time.time(),
    }
    if solution.status != "solved":
        return {**_failed(fleet, solution.status, ""), "solve": figures}
    timed = _joins_last(timed_moves(solution.paths, pending), joins)
    for k in order:  # the parked robots' places in the new numbering
        if k not in agents and robots[k]["moves"]:
            robots[k] = {
                **robots[k],
                "moves": [
                    [_renumber(u, robots[k], old_extras, graph, extras),
                     _renumber(v, robots[k], old_extras, graph, extras), t]
                    for u, v, t in robots[k]["moves"]
                ],
            }  # fmt: skip
    index = {k: j for j, k in enumerate(agents)}
    new = {}
    for k in order:
        robot = dict(robots[k])
        if k in index:
            j = index[k]
            moves = [list(m) for m in timed[j]]
            robot["moves"] = moves
            robot["told"] = sum(1 for m in moves if m[2] < 0) - (j in joins)
            robot["done"] = 0
            robot["node"] = int(solution.paths[0, j])
            robot["agent"] = j
        else:
            robot["agent"] = -1
        new[k] = robot
    return {
        **fleet,
        "robots": new,
        "agents": agents,
        "extras": extras,
        "dirty": False,
        "failed_at": None,
        "solve_id": secrets.token_hex(8),
        "solve": figures,
    }


def _join(
    fleet_map: FleetMap,
    cell: list[int],
    goal: int,
    taken: set[int],
    others: list[npt.NDArray[np.float64]],
    reach: float,
) -> int:
    """The node a robot at ``cell`` heading for node ``goal`` joins the roadmap at: the best
    (:func:`planner.fleets.attach`'s) it reaches by a straight move that keeps ``reach`` from
    every other robot's place, else the best of all (then it waits for the robot in its way);
    -1 when none is in reach."""
    graph, point = fleet_map.graph, np.array(cell, dtype=np.float64)
    rejected = set(taken)
    first = -1
    for _ in range(12):
        node = attach(graph, fleet_map.analysis, cell, exclude=rejected, toward=goal)
        if node < 0:
            break
        first = node if first < 0 else first
        target = graph.cells[node].astype(np.float64)
        clear = all(
            segment_distances(
                point, target, p[:-1] if len(p) > 1 else p, p[1:] if len(p) > 1 else p
            ).min()
            >= reach
            for p in others
        )
        if clear:
            return int(node)
        rejected.add(int(node))
    return first


def _joins_last(moves: list[list[Move]], joins: list[int]) -> list[list[Move]]:
    """The moves with each joining agent's move onto the roadmap (its last before time 0) at
    a plan time of its own, one after another in the order they joined, after every move told
    before the solve: joining robots then go one at a time where they would come close, and
    only once the moves in progress near them are done."""
    out = [list(own) for own in moves]
    offset = len(joins) + 1
    for own in out:
        for m, (u, v, t) in enumerate(own):
            if t < 0:
                own[m] = (u, v, t - offset)
    for order, j in enumerate(joins):
        own = out[j]
        last = max(m for m, move in enumerate(own) if move[2] < 0)
        u, v, _ = own[last]
        own[last] = (u, v, order - len(joins))
    return out


def node_cell(
    node: int, robot: dict[str, Any], old_extras: list[list[int]], graph: Graph
) -> list[int]:
    """The cell of a chain's node: a roadmap node's, a place off the roadmap of the last solve
    (``old_extras``), or (-1) the robot's own ``cell``: where it was reported or started."""
    if 0 <= node < graph.nodes:
        return [int(v) for v in graph.cells[node]]
    if node >= graph.nodes:
        return [int(v) for v in old_extras[node - graph.nodes]]
    return [int(v) for v in robot["cell"]]


def _renumber(
    node: int,
    robot: dict[str, Any],
    old_extras: list[list[int]],
    graph: Graph,
    extras: list[list[int]],
) -> int:
    """A node of the robot's chain in the new solve's numbering: roadmap nodes keep theirs;
    a place off the roadmap is added to ``extras``."""
    if 0 <= node < graph.nodes:
        return node
    extras.append(node_cell(node, robot, old_extras, graph))
    return graph.nodes + len(extras) - 1


def _failed(fleet: FleetRecord, status: str, why: str) -> FleetRecord:
    solve_ = {**fleet.get("solve", {}), "status": status, "at": time.time()}
    if why:
        solve_["detail"] = why
    # Still marked: tried again after a while (``fleets._may_solve``), or at the next change.
    return {**fleet, "dirty": True, "failed_at": time.time(), "solve": solve_}

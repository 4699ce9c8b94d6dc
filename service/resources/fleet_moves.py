"""A fleet robot's answer (docs/fleets.md): the moves of its joint plan whose predecessors are
done, within its horizon, cut where the client's obstacles block them or where a robot outside
the plan stands; its poses through those moves only, on straight lines; and its session and
fleet entry brought up to date."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import numpy.typing as npt

import planner
from planner.fleets import Schedule, segment_distances
from service.resources.fleet_solve import FleetMap, chain, node_cell
from service.stores.base import FleetRecord

__all__ = ["advance"]

_GONE = 1 << 60
"""The moves done of a robot that left its fleet: all of them (it no longer stands anywhere)."""
_COMPASS = ("E", "NE", "N", "NW", "W", "SW", "S", "SE")


def advance(
    plan_id: str,
    state: FleetRecord,
    plan_of: Schedule | None,
    fmap: FleetMap,
    session: planner.Session,
    obstacles: Any,
    *,
    position: Any,
    here: tuple[int, int] | None,
    seq: int | None,
    now: float,
    lease: float,
) -> tuple[planner.Step, str | None]:
    """Decide the robot's answer in ``state`` (changed in place: its entry, and the nodes its
    client's obstacles kept blocked for ``patience`` steps) and ``session``'s state."""
    plan = session.plan
    robots = state["robots"]
    me = robots[plan_id]
    graph, extras = fmap.graph, state.get("extras", [])
    moves = me["moves"]
    told = me["told"] = max(me["told"], me["done"])
    agents = state.get("agents", [])
    end, waiting_for = told, None
    j = int(me.get("agent", -1))
    planned = plan_of is not None and 0 <= j < len(agents) and agents[j] == plan_id
    if planned and plan_of is not None and len(plan_of.moves[j]) == len(moves):
        end, blocker = plan_of.ready(j, told, _Done(robots, agents))
        waiting_for = None if blocker is None else agents[blocker]
    cell = np.array(here if here is not None else session.state.position, dtype=np.float64)
    horizon = max(float(plan.params.horizon_m) / graph.resolution, 1.0)
    blocked = _dilated(obstacles, plan.params.dynamic_margin, graph.shape)
    allowed, length, held = told, 0.0, False
    places = _places(plan_id, state, fmap, extras) if end > told else None
    for k in range(told, end):
        a = np.array(node_cell(moves[k][0], me, extras, graph), dtype=np.float64)
        b = np.array(node_cell(moves[k][1], me, extras, graph), dtype=np.float64)
        if k > told and length >= horizon:
            break
        if blocked and _crosses(a, b, blocked, graph.shape):
            held = k == told
            break
        assert places is not None
        other = _too_close(a, b, places)
        if other is not None:
            waiting_for = other
            break
        allowed, length = k + 1, length + float(np.linalg.norm(b - a))
    me["held"] = int(me.get("held", 0)) + 1 if held else 0
    if held and me["held"] >= max(1, int(plan.params.patience)):
        # Blocked for ``patience`` steps: its next node is left out of the fleet's next solve.
        state["blocked"] = {**state.get("blocked", {}), str(moves[told][1]): now + lease}
        state["dirty"] = True
        me["held"] = 0
    new = [moves[k][1] for k in range(told, allowed)]
    if new:
        me["told"] = allowed
        status = "yielding" if me.get("arrived") else "moving"
        target = tuple(node_cell(new[-1], me, extras, graph))
    else:
        target = tuple(int(v) for v in cell)
        last = chain(me)[-1]
        at_goal = told >= len(moves) and last == me["goal_node"] and plan_of is not None
        status = "arrived" if at_goal or (told >= len(moves) and me.get("arrived")) else "waiting"
    if status == "arrived":
        me["arrived"] = True
    if status != "waiting":
        waiting_for = None
    ahead = [node_cell(m[1], me, extras, graph) for m in moves[me["done"] : me["told"]]]
    step = _answer(
        session, position, cell, ahead, target, status, seq, moves[me["told"] :], me, fmap, extras
    )
    me.update(
        cell=list(target), previous=[int(v) for v in step.previous], status=status,
        waiting_for=waiting_for,
    )  # fmt: skip
    return step, waiting_for


class _Done:
    """The moves each agent has done, read as the schedule asks (a robot gone: all of them)."""

    __slots__ = ("_agents", "_robots")

    def __init__(self, robots: dict[str, Any], agents: list[str]) -> None:
        self._robots, self._agents = robots, agents

    def __getitem__(self, agent: int) -> int:
        robot = self._robots.get(self._agents[agent])
        return _GONE if robot is None else int(robot["done"])

    def __len__(self) -> int:
        return len(self._agents)


def _answer(
    session: planner.Session,
    position: Any,
    cell: npt.NDArray[np.float64],
    ahead: list[list[int]],
    target: tuple[int, ...],
    status: str,
    seq: int | None,
    later: list[list[int]],
    me: dict[str, Any],
    fmap: FleetMap,
    extras: list[list[int]],
) -> planner.Step:
    """The step's answer, recorded in the session's state as a lone robot's step is."""
    st = session.state
    frame = session.plan.analysis.frame
    previous = st.position
    r, c = int(target[0]), int(target[1])
    moved = float(math.hypot(r - previous[0], c - previous[1]))
    if (r, c) != previous:
        st.trajectory.append((r, c))
    st.position = (r, c)
    st.iteration += 1
    st.path_length += moved
    st.arc_cost += moved
    st.status = status  # type: ignore[assignment]
    if seq is None:
        seq = 0 if st.last_seq is None else st.last_seq + 1
    points = frame.centers(np.array([cell.astype(np.int64).tolist(), *ahead]).reshape(-1, 2))
    yaw = None
    if isinstance(position, dict) and "x" in position:
        points[0] = (float(position["x"]), float(position["y"]))
        yaw = position.get("yaw")
    poses = _poses(points, frame.resolution, yaw, st.last_step)
    rest = _length(later, me, extras, fmap)
    along = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(poses))
    step = planner.Step(
        seq, previous, (r, c), _compass(previous, (r, c)), status,  # type: ignore[arg-type]
        st.iteration, st.path_length, st.arc_cost, rest, False, tuple(poses),
        along + rest * frame.resolution,
    )  # fmt: skip
    st.last_seq = seq
    st.last_step = step
    return step


def _length(
    moves: list[list[int]], me: dict[str, Any], extras: list[list[int]], fmap: FleetMap
) -> float:
    """The length of ``moves`` in cells (their nodes' cells looked up at once)."""
    if not moves:
        return 0.0
    ends = np.asarray(moves, dtype=np.int64)[:, :2]
    graph = fmap.graph
    if ends.min() >= 0 and ends.max() < graph.nodes:
        cells = graph.cells[ends].astype(np.float64)
    else:
        cells = np.array(
            [[node_cell(int(n), me, extras, graph) for n in pair] for pair in ends], np.float64
        )
    return float(np.hypot(*(cells[:, 1] - cells[:, 0]).T).sum())


def _poses(
    points: npt.NDArray[np.float64], resolution: float, yaw: Any, last: planner.Step | None
) -> list[tuple[float, float, float]]:
    """Poses along the straight segments through ``points`` (meters), at most one resolution
    apart, each heading along its segment (turns happen in place, at the nodes)."""
    heading = float(yaw) if yaw is not None else (last.poses[-1][2] if last and last.poses else 0.0)
    out = [(float(points[0][0]), float(points[0][1]), heading)]
    for (x1, y1), (x2, y2) in itertools.pairwise(points):
        dx, dy = float(x2 - x1), float(y2 - y1)
        span = math.hypot(dx, dy)
        if span < 1e-9:
            continue
        heading = math.atan2(dy, dx)
        out[-1] = (out[-1][0], out[-1][1], heading) if len(out) == 1 else out[-1]
        pieces = max(1, math.ceil(span / (resolution * 0.9999)))
        for i in range(1, pieces + 1):
            out.append((float(x1) + dx * i / pieces, float(y1) + dy * i / pieces, heading))
    return out


def _compass(a: tuple[int, int], b: tuple[int, int]) -> str:
    if a == b:
        return "WAIT"
    angle = math.atan2(-(b[0] - a[0]), b[1] - a[1])
    return _COMPASS[round(angle / (math.pi / 4)) % 8]


def _dilated(obstacles: Any, margin: int, shape: tuple[int, int]) -> set[int]:
    """The flat cells the client's obstacles block, with ``margin`` cells around each."""
    cells = np.asarray(obstacles, dtype=np.int64).reshape(-1, 2)
    if not len(cells):
        return set()
    out: set[int] = set()
    height, width = shape
    for dr in range(-margin, margin + 1):
        for dc in range(-margin, margin + 1):
            r, c = cells[:, 0] + dr, cells[:, 1] + dc
            keep = (r >= 0) & (r < height) & (c >= 0) & (c < width)
            out.update((r[keep] * width + c[keep]).tolist())
    return out


def _crosses(
    a: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    blocked: set[int],
    shape: tuple[int, int],
) -> bool:
    """Whether the segment from cell ``a`` to cell ``b`` passes a blocked cell."""
    pieces = max(1, math.ceil(float(np.abs(b - a).max()) * 4))
    t = np.linspace(0.0, 1.0, pieces + 1)[:, None]
    cells = np.rint(a + (b - a) * t).astype(np.int64)
    flat = cells[:, 0] * shape[1] + cells[:, 1]
    return any(int(f) in blocked for f in np.unique(flat))


def _places(
    plan_id: str, state: FleetRecord, fmap: FleetMap, extras: list[list[int]]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], list[str]]:
    """The places of the other robots that the joint plan does not order against this one
    (parked, or outside the last solve: the plan keeps the others apart): the segments of
    their told moves, or the points they stand on, as arrays of starts, ends, the distance each
    must keep from this robot (both radii, in cells) and whose each is."""
    robots = state["robots"]
    me = robots[plan_id]
    res = fmap.graph.resolution
    planned = set(state.get("agents", ())) if me.get("agent", -1) >= 0 else set()
    starts, ends, reach, owner = [], [], [], []
    for k, other in robots.items():
        if k == plan_id or (k in planned and not other.get("parked")):
            continue
        cells = [node_cell(n, other, extras, fmap.graph) for n in chain(other)]
        pairs = list(itertools.pairwise(cells)) if len(cells) > 1 else [(cells[0], cells[0])]
        for a, b in pairs:
            starts.append(a)
            ends.append(b)
            # Both radii apart; robots of radius 0 at least half a cell (never one cell).
            reach.append(max((float(me["radius"]) + float(other["radius"])) / res, 0.5))
            owner.append(k)
    return (
        np.array(starts, dtype=np.float64).reshape(-1, 2),
        np.array(ends, dtype=np.float64).reshape(-1, 2),
        np.array(reach, dtype=np.float64),
        owner,
    )


def _too_close(
    a: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    places: tuple[
        npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], list[str]
    ],
) -> str | None:
    """The first of ``places``' robots that may be within both radii of the move from ``a``
    to ``b`` (anywhere on its own told moves)."""
    starts, ends, reach, owner = places
    if not len(owner):
        return None
    close = np.nonzero(segment_distances(a, b, starts, ends) < reach - 1e-9)[0]
    return owner[int(close[0])] if len(close) else None

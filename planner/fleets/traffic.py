"""The rules of a fleet's traffic for one robot's step (docs/fleets.md): what it must not enter
(the other robots, with both radii; the passages others hold), and what its fleet records of
it afterwards (where it stands and was told to go, what it holds, waits at and waits for)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from planner.fleets.robots import Robot, robot_cells
from planner.fleets.waiting import WaitingZones

__all__ = ["NO_TRAFFIC", "YIELD_STEPS", "Traffic", "after_step", "traffic_for"]


@dataclass(frozen=True, slots=True)
class Traffic:
    """What one robot's step must keep clear of, by its fleet."""

    robots: npt.NDArray[np.int64]
    """``(n, 2)`` cells within the sum of radii of another robot's cell or target."""
    closed: Mapping[int, str]
    """Passage group -> the plan_id it is closed for (its holder, or the robot of higher
    priority waiting at it)."""
    zones: npt.NDArray[np.int64]
    """``(m, 2)`` cells of the closed groups' zones."""
    on_goal: tuple[str, ...] = ()
    """The robots (by rank) whose cells, as this step blocks them, cover the robot's goal."""
    beside_waiter: bool = False
    """Whether a robot of lower priority (higher rank) that waited on its last step stands
    next to this one (within the sum of radii and a margin and two cells): held up by each
    other, the lower one searches its way round first (:data:`YIELD_STEPS`)."""

    def obstacles(
        self, given: npt.NDArray[np.int64], *, open_zones: bool = False
    ) -> npt.NDArray[np.int64]:
        """The step's obstacles: the client's ``given`` cells, the robots' and (unless
        ``open_zones``) the closed passages' zones."""
        parts = [given, self.robots] if open_zones else [given, self.robots, self.zones]
        return np.ascontiguousarray(np.concatenate(parts).astype(np.int64, copy=False))


NO_TRAFFIC = Traffic(np.empty((0, 2), np.int64), {}, np.empty((0, 2), np.int64))
"""Nothing to keep clear of: a robot on its goal, which stays there whatever the others do."""

YIELD_STEPS = 4
"""Times its ``patience`` a held-up robot beside a waiting robot of lower priority puts off
searching its way round: two robots that block each other and search at once go round the same
way, meet again, and can do so for ever (symmetry); the one of lower priority searches first,
round the other standing still. Bounded: the other may be unable to move at all."""

NEAR = 4
"""Cells (Chebyshev) around the robot within which a robot standing on its goal blocks it: more
than a move and the decision's ``dynamic_margin`` reach."""


def traffic_for(
    plan_id: str,
    robots: Mapping[str, Robot],
    *,
    resolution: float,
    shape: tuple[int, int],
    zones: WaitingZones | None = None,
    here: tuple[int, int] | None = None,
    margin: int = 1,
    within: int | None = None,
) -> Traffic:
    """What the fleet's ``robots`` block for ``plan_id``'s step (the robot at ``here``, else
    where it was told to be): every other robot's cell and target with both radii, and the
    zone of every passage group that another robot holds or that a robot of higher priority
    (lower rank) waits at and ``plan_id`` does not hold. A holder that has come out of a
    group's neck (``leaving``) and waits for ``plan_id`` (standing on its goal, say) hands it
    the group: neither it nor the robots waiting at it close it to ``plan_id``, whose going in
    frees the holder's way.

    A robot standing on this one's goal blocks only the cells this step could reach (its
    decision's ``margin`` included): the robot still approaches its goal, its searches
    finding the way there, and it waits beside the other, never inside its radius. (Blocked
    whole, it would never leave its start: robots whose goals are each other's starts would
    wait for each other forever.)

    With ``within`` (cells), robots farther than that from this one are left out of its
    obstacles: they cannot meet it this step, and its searches then plan through them as
    through any moving obstacle, seeing them when they come near."""
    me = robots[plan_id]
    r, c = me.target if here is None else here
    gr, gc = me.goal
    groups = zones.count if zones is not None else 0
    # Each robot's groups read from the zones' flat array (every step reads them all).
    group_of = zones.group.item if zones is not None and groups else None
    width = zones.shape[1] if zones is not None else 0
    mine = set() if group_of is None else {group_of(x * width + y) for x, y in (me.cell, me.target)}
    on_goal: list[tuple[int, str]] = []
    nearby: list[Robot] = []
    beside_waiter = False
    closed_by: dict[int, tuple[int, str]] = {}  # group -> (rank, plan_id) of its holder
    wanted_by: dict[int, tuple[int, str]] = {}  # group -> the first waiting at it ahead of me
    handed: set[int] = set()  # groups whose holder, leaving, waits for me
    for k, o in robots.items():
        if k == plan_id:
            continue
        reach = (me.radius + o.radius) / resolution
        (cr, cc), (tr, tc) = o.cell, o.target
        far = reach + margin + 1  # beyond it from the goal on an axis, it cannot hold it
        if (
            (abs(cr - gr) <= far and abs(cc - gc) <= far)
            or (abs(tr - gr) <= far and abs(tc - gc) <= far)
        ) and _holds(me.goal, o, reach, margin):
            on_goal.append((o.rank, k))
        else:
            apart = min(max(abs(cr - r), abs(cc - c)), max(abs(tr - r), abs(tc - c)))
            if within is None or apart <= within + reach:
                nearby.append(o)
            if o.status == "waiting" and o.rank > me.rank and apart <= reach + margin + 2:
                beside_waiter = True
        if group_of is not None:
            # A robot holds the groups whose zones hold its cell or its target.
            held = group_of(cr * width + cc)
            held_too = group_of(tr * width + tc)
            if o.waiting_for == plan_id and o.leaving is not None and o.leaving >= 0:
                # Come out of the group's neck and waiting for me: I take its turn.
                handed.add(o.leaving)
                held = -1 if held == o.leaving else held
                held_too = -1 if held_too == o.leaving else held_too
            if held >= 0 and held not in mine:
                _first(closed_by, held, (o.rank, k))
            if held_too >= 0 and held_too != held and held_too not in mine:
                _first(closed_by, held_too, (o.rank, k))
            wants = o.wants  # a group of these zones (a stored value: checked)
            if wants is not None and 0 <= wants < groups and wants not in mine and o.rank < me.rank:
                _first(wanted_by, wants, (o.rank, k))
    on_goal.sort()
    cells = robot_cells(me.radius, nearby, resolution=resolution, shape=shape, margin=margin)
    if on_goal:
        near = robot_cells(
            me.radius, [robots[k] for _, k in on_goal], resolution=resolution, shape=shape,
            margin=margin,
        )  # fmt: skip
        reach = NEAR + margin
        keep = (np.abs(near[:, 0] - r) <= reach) & (np.abs(near[:, 1] - c) <= reach)
        cells = np.concatenate((cells, near[keep]))
    # A group another robot holds is closed for its holder; else, one a robot ahead waits at
    # for that robot: the holders are merged last, so they win.
    for g in handed:  # a holder's turn: ahead of the robots waiting at it
        wanted_by.pop(g, None)
    closed = {g: k for g, (_, k) in sorted({**wanted_by, **closed_by}.items())}
    zone_cells = np.empty((0, 2), np.int64)
    if zones is not None and closed:
        zone_cells = np.concatenate([zones.group_cells[g] for g in closed])
    return Traffic(cells, closed, zone_cells, tuple(k for _, k in on_goal), beside_waiter)


def _first(by: dict[int, tuple[int, str]], group: int, robot: tuple[int, str]) -> None:
    """Keeps in ``by[group]`` the robot of lowest rank (``(rank, plan_id)``)."""
    if group not in by or robot < by[group]:
        by[group] = robot


def _holds(goal: tuple[int, int], o: Robot, reach: float, margin: int) -> bool:
    """Whether robot ``o``'s cells, grown by the decision's ``margin``, hold ``goal``: it is
    within ``reach`` (the sum of radii, cells) of its cell or target (as :func:`covering`
    finds), or the margin brings it there (as :func:`robot_cells` gives the disks: of the
    eroded radius about cell and target; is one within Chebyshev ``margin`` of the goal?)."""
    gr, gc = goal
    far = reach + margin + 1  # beyond it on an axis, neither test holds
    eroded = reach
    if margin > 0:
        eroded = 0.0 if reach <= margin else math.hypot(reach - margin, margin)
    for r, c in (o.cell, o.target):
        dr, dc = abs(r - gr), abs(c - gc)
        if dr > far or dc > far:
            continue
        if dr * dr + dc * dc <= reach * reach + 1e-9:
            return True
        nr, nc = max(dr - margin, 0), max(dc - margin, 0)
        if nr * nr + nc * nc <= eroded * eroded + 1e-9:
            return True
    return False


def after_step(
    me: Robot,
    *,
    previous: tuple[int, int],
    position: tuple[int, int],
    status: str,
    traffic: Traffic,
    zones: WaitingZones | None,
    would_enter: int | None = None,
) -> Robot:
    """The robot as its fleet records it after a step that told it to go from ``previous`` to
    ``position`` with ``status``: it holds every passage group whose zone holds either cell; it
    is *leaving* the group whose zone holds ``position`` out of its neck when ``previous`` was
    in the neck, or was where it was leaving the group from before; waiting, it waits at the
    closed group it ``would_enter`` (the group's holder is whom it waits for), else for the
    robot standing on its goal, if any."""
    holds: tuple[int, ...] = ()
    leaving = None
    if zones is not None and zones.count:
        holds = tuple(sorted(zones.groups_of(previous, position)))
        group = zones.group_at(position)
        if (
            group >= 0
            and not zones.in_neck(position)
            and (
                (me.leaving == group and me.target == previous)
                or (zones.in_neck(previous) and zones.group_at(previous) == group)
            )
        ):
            leaving = group
    waiting = status == "waiting"
    wants = would_enter if waiting and would_enter is not None else None
    waiting_for = None
    if wants is not None:
        waiting_for = traffic.closed.get(wants)
    elif waiting and traffic.on_goal:
        waiting_for = traffic.on_goal[0]
    return me.moved(
        previous, position, status, holds=holds, wants=wants, waiting_for=waiting_for,
        leaving=leaving,
    )  # fmt: skip

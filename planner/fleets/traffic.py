"""The rules of a fleet's traffic for one robot's step (docs/fleets.md): what it must not enter
(the other robots, with both radii; the passages others hold), and what its fleet records of
it afterwards (where it stands and was told to go, what it holds, waits at and waits for)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from planner.fleets.robots import Robot, covering, robot_cells
from planner.fleets.waiting import WaitingZones

__all__ = ["Traffic", "after_step", "traffic_for"]


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

    def obstacles(
        self, given: npt.NDArray[np.int64], *, open_zones: bool = False
    ) -> npt.NDArray[np.int64]:
        """The step's obstacles: the client's ``given`` cells, the robots' and (unless
        ``open_zones``) the closed passages' zones."""
        parts = [given, self.robots] if open_zones else [given, self.robots, self.zones]
        return np.ascontiguousarray(np.concatenate(parts).astype(np.int64, copy=False))


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
    (lower rank) waits at and ``plan_id`` does not hold.

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
    others = {k: v for k, v in robots.items() if k != plan_id}
    on_goal = _on_goal(me, others, resolution=resolution, shape=shape, margin=margin)
    nearby = [
        o
        for k, o in others.items()
        if k not in on_goal
        and (
            within is None
            or min(
                max(abs(o.cell[0] - r), abs(o.cell[1] - c)),
                max(abs(o.target[0] - r), abs(o.target[1] - c)),
            )
            <= within + (me.radius + o.radius) / resolution
        )
    ]
    cells = robot_cells(me.radius, nearby, resolution=resolution, shape=shape, margin=margin)
    if on_goal:
        near = robot_cells(
            me.radius, [others[k] for k in on_goal], resolution=resolution, shape=shape,
            margin=margin,
        )  # fmt: skip
        reach = NEAR + margin
        keep = (np.abs(near[:, 0] - r) <= reach) & (np.abs(near[:, 1] - c) <= reach)
        cells = np.concatenate((cells, near[keep]))
    closed: dict[int, str] = {}
    if zones is not None and zones.count:
        # A robot holds the groups whose zones hold its cell or its target.
        mine = zones.groups_of(me.cell, me.target)
        held = {k: zones.groups_of(o.cell, o.target) for k, o in others.items()}
        for group in range(zones.count):
            if group in mine:
                continue
            holders = sorted((others[k].rank, k) for k, gs in held.items() if group in gs)
            ahead = sorted(
                (o.rank, k) for k, o in others.items() if o.wants == group and o.rank < me.rank
            )
            if holders or ahead:
                closed[group] = (holders or ahead)[0][1]
    zone_cells = np.empty((0, 2), np.int64)
    if zones is not None and closed:
        zone_cells = np.concatenate([zones.group_cells[g] for g in sorted(closed)])
    return Traffic(cells, closed, zone_cells, tuple(on_goal))


def _on_goal(
    me: Robot,
    others: Mapping[str, Robot],
    *,
    resolution: float,
    shape: tuple[int, int],
    margin: int,
) -> list[str]:
    """The robots (by rank) whose cells, grown by the decision's ``margin``, hold ``me``'s
    goal: those within the sum of radii of it (:func:`covering`), and those the margin brings
    to it."""
    found = set(covering(me.goal, me.radius, others, resolution=resolution))
    rest = [k for k in others if k not in found]
    if rest:
        # As robot_cells gives them: disks of the eroded radius about cells and targets; is
        # one within Chebyshev ``margin`` of the goal?
        reach = np.array([(me.radius + others[k].radius) / resolution for k in rest])
        if margin > 0:
            eroded = np.hypot(reach - margin, margin)
            reach = np.where(reach <= margin, 0.0, eroded)
        centers = np.array([[others[k].cell, others[k].target] for k in rest], dtype=np.int64)
        gap = np.abs(centers - np.array(me.goal, dtype=np.int64))  # (n, 2 centers, 2 axes)
        near = np.maximum(gap - margin, 0).astype(np.float64)  # the window's nearest cell
        squared = (near**2).sum(axis=2).min(axis=1)
        found |= {k for k, hit in zip(rest, squared <= reach**2 + 1e-9, strict=True) if hit}
    return sorted(found, key=lambda k: others[k].rank)


def after_step(
    me: Robot,
    others: Mapping[str, Robot],
    *,
    previous: tuple[int, int],
    position: tuple[int, int],
    status: str,
    traffic: Traffic,
    zones: WaitingZones | None,
    resolution: float,
    would_enter: int | None = None,
) -> Robot:
    """The robot as its fleet records it after a step that told it to go from ``previous`` to
    ``position`` with ``status``: it holds every passage group whose zone holds either cell;
    waiting, it waits at the closed group it ``would_enter`` (the group's holder is whom it
    waits for), else for the robot standing on its goal, if any."""
    holds: tuple[int, ...] = ()
    if zones is not None and zones.count:
        holds = tuple(sorted(zones.groups_of(previous, position)))
    waiting = status == "waiting"
    wants = would_enter if waiting and would_enter is not None else None
    waiting_for = None
    if wants is not None:
        waiting_for = traffic.closed.get(wants)
    elif waiting and traffic.on_goal:
        waiting_for = traffic.on_goal[0]
    return me.moved(previous, position, status, holds=holds, wants=wants, waiting_for=waiting_for)

"""Slow obvious references for the fleet's traffic (planner.fleets): the other robots' disks
as numpy offsets, and ``traffic_for`` as first written, with sorted lists of holders and
waiters for every passage group. The planner's one-pass loop and its disk kernel are checked
against them (tests/planner/test_fleets.py)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from functools import lru_cache
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.fleets.waiting import WaitingZones

NEAR = 4


@lru_cache(maxsize=256)
def _offsets(squared: float) -> npt.NDArray[np.int64]:
    reach = math.isqrt(math.floor(squared))
    span = np.arange(-reach, reach + 1, dtype=np.int64)
    dr, dc = np.meshgrid(span, span, indexing="ij")
    inside = dr * dr + dc * dc <= squared
    out = np.stack((dr[inside], dc[inside]), axis=1)
    out.setflags(write=False)
    return out


def robot_cells(
    radius: float,
    others: Iterable[Any],
    *,
    resolution: float,
    shape: tuple[int, int],
    margin: int = 0,
) -> npt.NDArray[np.int64]:
    """The cells (an ``(n, 2)`` array, inside the map) a robot of ``radius`` meters must not be
    told to enter because of the ``others``: every cell whose center is within the sum of both
    radii of another robot's ``cell`` or ``target``, once the step's decision has blocked every
    cell within Chebyshev ``margin`` of them (its ``dynamic_margin``).

    With a margin, fewer cells are given: a disk of radius ``sqrt((R - m)^2 + m^2)`` (cells;
    just the center when ``R <= m``), whose cells within Chebyshev ``m`` cover every cell
    within ``R`` (from a cell at distance ``d <= R``, the move by ``m`` toward the center on
    each axis lands within that radius), and no more than the margin needs: a robot beside
    a wall is not boxed in by a disk grown by a margin it already has."""
    H, W = shape
    parts = []
    for other in others:
        reach = (radius + other.radius) / resolution
        if margin > 0:
            reach = 0.0 if reach <= margin else math.hypot(reach - margin, margin)
        (r, c), (tr, tc) = other.cell, other.target
        offsets = _pair(round(reach * reach + 1e-9, 9), tr - r, tc - c)
        parts.append(offsets + np.array([r, c], dtype=np.int64))
    if not parts:
        return np.empty((0, 2), dtype=np.int64)
    cells = np.concatenate(parts) if len(parts) > 1 else parts[0]
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < H) & (cells[:, 1] >= 0) & (cells[:, 1] < W)
    out: npt.NDArray[np.int64] = cells if inside.all() else cells[inside]
    return out


@lru_cache(maxsize=1024)
def _pair(squared: float, dr: int, dc: int) -> npt.NDArray[np.int64]:
    """The offsets of the disk about ``(0, 0)`` and of the disk about ``(dr, dc)``, each
    once (a robot's cell and its target are a move apart: the union, computed once a shape)."""
    disk = _offsets(squared)
    if dr == 0 and dc == 0:
        return disk
    both = np.concatenate((disk, disk + np.array([dr, dc], dtype=np.int64)))
    out = np.unique(both, axis=0)
    out.setflags(write=False)
    return out


def covering(
    cell: tuple[int, int], radius: float, others: Mapping[str, Any], *, resolution: float
) -> list[str]:
    """The plan_ids of the robots (by rank) standing where a robot of ``radius`` meters at
    ``cell`` would touch them (within the sum of both radii of their cell or target)."""
    found: list[tuple[int, str]] = []
    for plan_id, other in others.items():
        reach = (radius + other.radius) / resolution
        if any(
            (r - cell[0]) ** 2 + (c - cell[1]) ** 2 <= reach * reach + 1e-9
            for r, c in (other.cell, other.target)
        ):
            found.append((other.rank, plan_id))
    return [plan_id for _, plan_id in sorted(found)]


def traffic_for(
    plan_id: str,
    robots: Mapping[str, Any],
    *,
    resolution: float,
    shape: tuple[int, int],
    zones: WaitingZones | None = None,
    here: tuple[int, int] | None = None,
    margin: int = 1,
    within: int | None = None,
) -> tuple[npt.NDArray[np.int64], dict[int, str], npt.NDArray[np.int64], tuple[str, ...]]:
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
    return cells, closed, zone_cells, tuple(on_goal)


def _on_goal(
    me: Any,
    others: Mapping[str, Any],
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

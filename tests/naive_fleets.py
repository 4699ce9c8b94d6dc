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

from planner.fleets.robots import covering
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
    """``planner.fleets.robot_cells``: each robot's two disks as offsets about the origin,
    shifted, their union by ``numpy.unique``, the cells off the map dropped."""
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
    """``planner.fleets.traffic_for``'s ``(robots, closed, zones, on_goal)``, group by group:
    each group's holders and the robots ahead waiting at it, sorted, the first taken."""
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
        # A holder leaving a group that waits for me hands it to me, ahead of the waiters.
        handing = {
            k: o.leaving
            for k, o in others.items()
            if o.waiting_for == plan_id and o.leaving is not None and o.leaving >= 0
        }
        handed = set(handing.values())
        for group in range(zones.count):
            if group in mine:
                continue
            holders = sorted(
                (others[k].rank, k)
                for k, gs in held.items()
                if group in gs and handing.get(k) != group
            )
            ahead = sorted(
                (o.rank, k)
                for k, o in others.items()
                if o.wants == group and o.rank < me.rank and group not in handed
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

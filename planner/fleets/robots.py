"""A fleet's shared state (docs/fleets.md): where each robot stands, where it was last told to
go, its size, and what it waits for; plain data that a store writes atomically with the
stepping robot's plan. And what the other robots block for one robot's step."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["Robot", "covering", "robot_cells"]

Cell = tuple[int, int]


class Robot(NamedTuple):
    """One robot of a fleet as its fleet keeps it (a named tuple: every step rebuilds every
    robot of its fleet, and tuples are the cheapest to build).

    It physically occupies ``cell`` (where it stood when last told) and ``target`` (the cell it
    was told to move to, where the service records it) until its next step; a robot that never
    stepped has both at its start.
    """

    rank: int
    """Its priority: the order it joined the fleet in (lower first)."""
    cell: Cell
    target: Cell
    radius: float
    """Meters."""
    goal: Cell
    status: str = "ready"
    waiting_for: str | None = None
    """The plan_id of the robot it waits for (on its goal, or holding a passage it needs)."""
    holds: tuple[int, ...] = ()
    """The passage groups it holds (docs/fleets.md, "Passages")."""
    wants: int | None = None
    """The passage group it waits at the border of, if any."""
    leaving: int | None = None
    """The passage group it is leaving: it came out of the group's neck and is in its zone
    still (docs/fleets.md, "Passages")."""
    until: float = math.inf
    """When its plan expires (seconds of the epoch): a robot whose plan expired is gone."""

    def as_dict(self) -> dict[str, Any]:
        return {
            "rank": self.rank,
            "cell": list(self.cell),
            "target": list(self.target),
            "radius": self.radius,
            "goal": list(self.goal),
            "status": self.status,
            "waiting_for": self.waiting_for,
            "holds": list(self.holds),
            "wants": self.wants,
            "leaving": self.leaving,
            "until": None if math.isinf(self.until) else self.until,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Robot:
        (r, c), (tr, tc), (gr, gc) = d["cell"], d["target"], d["goal"]
        until = d.get("until")
        return cls(
            d["rank"], (r, c), (tr, tc), float(d["radius"]), (gr, gc), d.get("status", "ready"),
            d.get("waiting_for"), tuple(d.get("holds", ())), d.get("wants"), d.get("leaving"),
            math.inf if until is None else float(until),
        )  # fmt: skip

    def moved(self, previous: Cell, position: Cell, status: str, **changes: Any) -> Robot:
        """This robot after a step that told it to go from ``previous`` to ``position``."""
        return self._replace(cell=previous, target=position, status=status, **changes)


def robot_cells(
    radius: float,
    others: Iterable[Robot],
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
    centers, squared = [], []
    for other in others:
        reach = (radius + other.radius) / resolution
        if not reach >= 0 or not math.isfinite(reach):
            raise ValueError(
                f"robot radii must be finite and >= 0; got {radius!r}, {other.radius!r}"
            )
        if margin > 0:
            reach = 0.0 if reach <= margin else math.hypot(reach - margin, margin)
        centers.append((*other.cell, *other.target))
        squared.append(round(reach * reach + 1e-9, 9))
    if not centers:
        return np.empty((0, 2), dtype=np.int64)
    return _robot_cells(  # type: ignore[no-any-return]
        np.array(centers, dtype=np.int64), np.array(squared), int(shape[0]), int(shape[1])
    )


@njit(cache=True, nogil=True)
def _robot_cells(centers: Any, squared: Any, H: int, W: int) -> Any:
    """The cells inside ``H`` x ``W`` whose centers are within ``sqrt(squared[i])`` of row
    ``i``'s cell ``(r, c)`` or target ``(tr, tc)`` (``centers[i]``), each robot's once."""
    spans = np.empty(centers.shape[0], dtype=np.int64)
    size = 0
    for i in range(centers.shape[0]):
        s = int(math.sqrt(math.floor(squared[i])))
        while (s + 1) * (s + 1) <= squared[i]:
            s += 1
        while s * s > squared[i]:
            s -= 1
        spans[i] = s
        size += 2 * (2 * s + 1) * (2 * s + 1)
    out = np.empty((size, 2), dtype=np.int64)
    n = 0
    for i in range(centers.shape[0]):
        r, c, tr, tc = centers[i, 0], centers[i, 1], centers[i, 2], centers[i, 3]
        s, q = spans[i], squared[i]
        for dr in range(-s, s + 1):
            for dc in range(-s, s + 1):
                if dr * dr + dc * dc > q:
                    continue
                if 0 <= r + dr < H and 0 <= c + dc < W:
                    out[n, 0], out[n, 1] = r + dr, c + dc
                    n += 1
                ar, ac = tr + dr - r, tc + dc - c  # the target's cell from the robot's
                if ar * ar + ac * ac > q and 0 <= tr + dr < H and 0 <= tc + dc < W:
                    out[n, 0], out[n, 1] = tr + dr, tc + dc
                    n += 1
    return out[:n].copy()


def covering(
    cell: Cell, radius: float, others: Mapping[str, Robot], *, resolution: float
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

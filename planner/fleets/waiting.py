"""Passage zones (docs/fleets.md, "Passages"): around each narrow passage's neck, the cells a
robot holds the passage in, reaching far enough past its mouths that a robot waiting outside
does not trap one coming out; passages whose zones come close are one group, held as one."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import edt
import numpy as np
import numpy.typing as npt

__all__ = [
    "WAIT_SLACK",
    "PassageLike",
    "WaitingZones",
    "no_waiting_zones",
    "wait_distance",
    "waiting_zones",
]

WAIT_SLACK = 0.2
"""Meters added to two robot diameters for the waiting distance (:func:`wait_distance`)."""


class PassageLike(Protocol):
    """What a zone needs of a passage (``planner.find_passages``'s ``Passage``)."""

    @property
    def id(self) -> int: ...

    @property
    def cells(self) -> npt.NDArray[np.int64]: ...


def wait_distance(robot_radius: float) -> float:
    """How far from a passage's neck (meters) a robot waits for it: two robot diameters and a
    little, so that a robot coming out can step out of the neck and round the waiting one
    (1.5 m for robots of 0.325 m, the waiting zone a prototype of these rules needed for a
    0.8 m corridor)."""
    return 4 * robot_radius + WAIT_SLACK


@dataclass(frozen=True, slots=True)
class WaitingZones:
    """Passage groups over a map: ``group`` (flat, ``-1`` outside every zone) and each group's
    passage ids."""

    shape: tuple[int, int]
    group: npt.NDArray[np.int32]
    passages: tuple[tuple[int, ...], ...]
    """Each group's passage ids."""
    found: tuple[Any, ...] = ()
    """The passages by id (``planner.find_passages``'s)."""
    group_cells: tuple[npt.NDArray[np.int64], ...] = ()
    """Each group's ``(n, 2)`` zone cells (made from ``group`` when not given)."""
    neck: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    """Flat: whether a cell is in a passage's neck (made from ``found`` when not given)."""

    def __post_init__(self) -> None:
        if len(self.group_cells) != len(self.passages):
            cells = tuple(self.cells_of([g]) for g in range(len(self.passages)))
            object.__setattr__(self, "group_cells", cells)
        if self.neck.size != self.group.size:
            neck = np.zeros(self.group.size, dtype=bool)
            for p in self.found:
                neck[np.asarray(p.cells, dtype=np.int64)] = True
            object.__setattr__(self, "neck", neck & (self.group >= 0))

    @property
    def count(self) -> int:
        return len(self.passages)

    @property
    def nbytes(self) -> int:
        """Bytes held (for a cache that counts them)."""
        cells = sum(int(p.cells.nbytes) for p in self.found) + int(self.neck.nbytes)
        return int(self.group.nbytes) + cells + sum(int(c.nbytes) for c in self.group_cells)

    def groups_of(self, *cells: tuple[int, int]) -> set[int]:
        """The groups whose zones hold any of ``cells``."""
        return {g for g in map(self.group_at, cells) if g >= 0}

    def group_at(self, cell: tuple[int, int]) -> int:
        """The group whose zone holds ``cell``, or -1."""
        return int(self.group.item(cell[0] * self.shape[1] + cell[1]))

    def in_neck(self, cell: tuple[int, int]) -> bool:
        """Whether ``cell`` is in a passage's neck."""
        return bool(self.neck.item(cell[0] * self.shape[1] + cell[1]))

    def near(self, cell: tuple[int, int], groups: Sequence[int], reach: int) -> bool:
        """Whether a cell within Chebyshev ``reach`` of ``cell`` is in one of ``groups``."""
        H, W = self.shape
        r, c = cell
        window = self.group.reshape(H, W)[
            max(0, r - reach) : r + reach + 1, max(0, c - reach) : c + reach + 1
        ]
        return bool(np.isin(window, np.asarray(groups, dtype=np.int32)).any())

    def cells_of(self, groups: Sequence[int]) -> npt.NDArray[np.int64]:
        """The ``(n, 2)`` cells of those groups' zones."""
        flat = np.flatnonzero(np.isin(self.group, np.asarray(groups, dtype=np.int32)))
        out: npt.NDArray[np.int64] = np.stack(np.divmod(flat, self.shape[1]), axis=1)
        return out.astype(np.int64, copy=False)


def no_waiting_zones(shape: tuple[int, int]) -> WaitingZones:
    """A map without passages."""
    return WaitingZones(shape, np.full(shape[0] * shape[1], -1, dtype=np.int32), ())


def waiting_zones(
    traversable: npt.NDArray[np.uint8],
    passages: Sequence[PassageLike],
    *,
    resolution: float,
    robot_radius: float,
    wait_m: float | None = None,
) -> WaitingZones:
    """The zones of ``passages`` over a configuration space's ``traversable`` cells: from each
    neck, the traversable cells reachable through traversable cells without going farther than
    ``wait_m`` (default :func:`wait_distance`) from the neck, so that a zone does not leak
    through a wall into the room behind it. Passages whose zones come within two robot
    diameters of each other form one group (a robot standing between them would block both):
    held as one, no robot holds one while waiting for the other."""
    shape = (int(traversable.shape[0]), int(traversable.shape[1]))
    if not passages:
        return no_waiting_zones(shape)
    reach = (wait_distance(robot_radius) if wait_m is None else wait_m) / resolution
    free = traversable.astype(bool)
    zones = []
    for p in passages:
        neck = np.zeros(shape, dtype=bool)
        neck.ravel()[np.asarray(p.cells, dtype=np.int64)] = True
        within = edt.edt(np.ascontiguousarray(~neck), black_border=False) <= reach
        zone = neck & free
        for _ in range(math.ceil(reach) + 1):
            grown = _dilate(zone) & free & within
            if (grown == zone).all():
                break
            zone = grown
        zones.append(zone | (neck & free))
    gap = 4 * robot_radius / resolution
    group = list(range(len(zones)))

    def root(i: int) -> int:
        while group[i] != i:
            group[i] = group[group[i]]
            i = group[i]
        return i

    for i, zone in enumerate(zones):
        if not zone.any():
            continue
        apart = edt.edt(np.ascontiguousarray(~zone), black_border=False)
        for j in range(i + 1, len(zones)):
            if zones[j].any() and apart[zones[j]].min() <= gap + 1:
                group[root(j)] = root(i)
    roots = sorted({root(i) for i in range(len(zones))})
    flat = np.full(shape[0] * shape[1], -1, dtype=np.int32)
    members: list[tuple[int, ...]] = []
    for g, r in enumerate(roots):
        ids = tuple(i for i in range(len(zones)) if root(i) == r)
        members.append(tuple(int(passages[i].id) for i in ids))
        for i in ids:
            flat[zones[i].ravel()] = g
    by_id = sorted(passages, key=lambda p: int(p.id))
    return WaitingZones(shape, flat, tuple(members), tuple(by_id))


def _dilate(mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """``mask`` grown by one cell, 8-connected."""
    out = mask.copy()
    out[1:] |= mask[:-1]
    out[:-1] |= mask[1:]
    grown = out.copy()
    grown[:, 1:] |= out[:, :-1]
    grown[:, :-1] |= out[:, 1:]
    return grown

"""Passage zones (docs/fleets.md, "Passages"): around each narrow passage's neck, the cells a
robot holds the passage in, reaching far enough past its mouths that a robot waiting outside
does not trap one coming out; passages whose zones come close are one group, held as one."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["Zones", "no_zones"]


@dataclass(frozen=True, slots=True)
class Zones:
    """Passage groups over a map: ``group`` (flat, ``-1`` outside every zone) and each group's
    passage ids."""

    shape: tuple[int, int]
    group: npt.NDArray[np.int32]
    passages: tuple[tuple[int, ...], ...]
    """Each group's passage ids."""
    found: tuple[Any, ...] = ()
    """The passages by id (``planner.find_passages``'s)."""

    @property
    def count(self) -> int:
        return len(self.passages)

    def group_at(self, cell: tuple[int, int]) -> int:
        """The group whose zone holds ``cell``, or -1."""
        return int(self.group[cell[0] * self.shape[1] + cell[1]])

    def cells_of(self, groups: Sequence[int]) -> npt.NDArray[np.int64]:
        """The ``(n, 2)`` cells of those groups' zones."""
        flat = np.flatnonzero(np.isin(self.group, np.asarray(groups, dtype=np.int32)))
        out: npt.NDArray[np.int64] = np.stack(np.divmod(flat, self.shape[1]), axis=1)
        return out.astype(np.int64, copy=False)


def no_zones(shape: tuple[int, int]) -> Zones:
    """A map without passages."""
    return Zones(shape, np.full(shape[0] * shape[1], -1, dtype=np.int32), ())

"""The live layer's marks (docs/live.md): each map's cells a scan saw blocked, with the time
each mark lapses; a later ray through a marked cell clears it. The memory store keeps them
here; the Redis store in a hash a map (``redis_live.py``)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from planner import Traced

__all__ = ["NO_MARKS", "LiveLayers", "Marks", "Seen", "cleared_among"]


@dataclass(frozen=True, slots=True)
class Seen:
    """A scan's update of a map's live layer: what it traced on a map ``width`` cells wide,
    its marks lasting ``seconds``."""

    traced: Traced
    width: int
    seconds: float


@dataclass(frozen=True, slots=True)
class Marks:
    """A map's live marks as a step decides on them: flat cells, sorted, and their ``digest``
    (the Redis store's fence: the step is written only if they are still the map's marks; ""
    where the store needs none)."""

    cells: npt.NDArray[np.int64]
    digest: str = ""


NO_MARKS = Marks(np.zeros(0, dtype=np.int64))


def cleared_among(cells: npt.NDArray[np.int64], seen: Seen) -> npt.NDArray[np.bool_]:
    """Which of ``cells`` (flat) the scan's rays cleared."""
    t, w = seen.traced, seen.width
    h, ww = t.cleared.shape
    r, c = cells // w - t.top, cells % w - t.left
    inside = (r >= 0) & (r < h) & (c >= 0) & (c < ww)
    out = np.zeros(len(cells), dtype=bool)
    out[inside] = t.cleared[r[inside], c[inside]] != 0
    return out


class LiveLayers:
    """Every map's marks in this process, by the map's scoped key: cell -> when it lapses."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._marks: dict[str, dict[int, float]] = {}

    def observe(self, key: str, seen: Seen) -> int:
        """Clear what the scan's rays crossed, mark its returns; the marks the map has now."""
        now = self._clock()
        marks = self._marks.get(key, {})
        cells = np.fromiter(marks.keys(), dtype=np.int64, count=len(marks))
        until = np.fromiter(marks.values(), dtype=np.float64, count=len(marks))
        keep = (until > now) & ~cleared_among(cells, seen)
        kept = dict(zip(cells[keep].tolist(), until[keep].tolist(), strict=True))
        lapse = now + seen.seconds
        kept.update(dict.fromkeys(seen.traced.marked.tolist(), lapse))
        if kept:
            self._marks[key] = kept
        else:
            self._marks.pop(key, None)
        return len(kept)

    def marks(self, key: str) -> npt.NDArray[np.int64]:
        """The map's marked cells now (flat, sorted)."""
        marks = self._marks.get(key)
        if not marks:
            return np.zeros(0, dtype=np.int64)
        now = self._clock()
        live = sorted(cell for cell, until in marks.items() if until > now)
        if len(live) < len(marks):
            self._marks[key] = {cell: marks[cell] for cell in live}
        return np.array(live, dtype=np.int64)

"""The Redis store's live layer (docs/live.md): a map's marks are one hash,
``planner:live:{map_id}``, cell -> the Redis time (ms) it lapses; a scan's update is one script
call. Each replica keeps the marks it last heard of each map (every script that reads them
answers them): a step decides on those, and its write checks they are still the map's, so a
step costs no round trip of its own for the marks."""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from typing import Any

import numpy as np
import numpy.typing as npt

from service.stores.live import NO_MARKS, Marks, Seen
from service.stores.redis_link import RedisLink
from service.stores.scripts import LIVE_MARKS, OBSERVE
from service.tenants import scoped

__all__ = ["CACHED_MARKS", "LiveMarks", "live_key"]

CACHED_MARKS = 4096
"""Maps whose marks each replica keeps (the least recently heard are dropped)."""
_EMPTY = hashlib.sha1(b"", usedforsecurity=False).hexdigest()


class LiveMarks:
    """The live layer's part of :class:`~service.stores.redis.RedisStore`."""

    def __init__(self, link: RedisLink) -> None:
        self._link = link
        self._observe = link.redis.register_script(OBSERVE)
        self._read = link.redis.register_script(LIVE_MARKS)
        # Scoped map id -> its marks as last heard, least recently heard first.
        self._heard: OrderedDict[str, Marks] = OrderedDict()

    async def observe(self, map_id: str, seen: Seen) -> int:
        t = seen.traced
        h, w = t.cleared.shape
        bits = np.packbits(t.cleared.reshape(-1)).tobytes()
        ms = max(1, round(seen.seconds * 1000))
        args: list[Any] = [ms, seen.width, t.top, t.left, h, w, bits, *t.marked.tolist()]
        with self._link.reaching:
            n, marks = await self._observe(keys=[live_key(map_id)], args=args)
        self.learn(map_id, marks)
        return int(n)

    async def live_marks(self, map_id: str) -> npt.NDArray[np.int64]:
        with self._link.reaching:
            value = await self._read(keys=[live_key(map_id)])
        return self.learn(map_id, value).cells

    def known(self, map_id: str) -> Marks:
        """The map's marks as this replica last heard them (none: no marks)."""
        found = self._heard.get(scoped(map_id))
        return Marks(NO_MARKS.cells, _EMPTY) if found is None else found

    def learn(self, map_id: str, value: bytes) -> Marks:
        """Keep the map's marks as a script answered them (``LIVE_MARKS``'s string)."""
        key = scoped(map_id)
        digest = hashlib.sha1(value, usedforsecurity=False).hexdigest()  # as redis.sha1hex
        found = self._heard.get(key)
        if found is None or found.digest != digest:
            found = Marks(np.array(list(map(int, value.split())), dtype=np.int64), digest)
        self._heard[key] = found
        self._heard.move_to_end(key)
        if len(self._heard) > CACHED_MARKS:
            self._heard.popitem(last=False)
        return found

    def learn_hash(self, map_id: str, marks: dict[bytes, bytes], now_us: int) -> None:
        """Keep the map's marks as ``HGETALL`` read them at Redis's time ``now_us``: those not
        lapsed, written as ``LIVE_MARKS`` writes them."""
        ms = now_us // 1000
        live = sorted(int(cell) for cell, until in marks.items() if int(until) > ms)
        self.learn(map_id, " ".join(map(str, live)).encode())


def live_key(map_id: str) -> str:
    """The key of the map's marks (the current tenant's)."""
    return f"planner:live:{scoped(map_id)}"

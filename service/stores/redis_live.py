"""The Redis store's live layer (docs/live.md): a map's marks are one hash,
``planner:live:{map_id}``, cell -> the Redis time (ms) it lapses; a scan's update is one
script call, and so is a step's read of the marks live now."""

from __future__ import annotations

from abc import ABC
from contextlib import AbstractContextManager
from typing import Any

import numpy as np
import numpy.typing as npt

from service.stores.live import Seen
from service.tenants import scoped

__all__ = ["LIVE_MARKS", "OBSERVE", "LiveLayer"]

_NOW = """
local clock = redis.call('TIME')
local ms = tonumber(clock[1]) * 1000 + math.floor(tonumber(clock[2]) / 1000)
"""

# A scan's update in one round trip: KEYS the map's marks; ARGV how long a mark lasts (ms), the
# map's width, the cleared window's top, left, height and width, its cells as bits (row-major,
# the first cell the high bit of the first byte), then the marked cells. Marks lapsed or
# cleared go, the scan's are (re)marked; the key lasts as long as its last mark. Returns how
# many marks the map has now.
OBSERVE = (
    _NOW
    + """
local W, top, left = tonumber(ARGV[2]), tonumber(ARGV[3]), tonumber(ARGV[4])
local h, w, bits = tonumber(ARGV[5]), tonumber(ARGV[6]), ARGV[7]
local all = redis.call('HGETALL', KEYS[1])
local gone = {}
for k = 1, #all, 2 do
  local drop = tonumber(all[k + 1]) <= ms
  if not drop then
    local cell = tonumber(all[k])
    local r, c = math.floor(cell / W) - top, cell % W - left
    if r >= 0 and r < h and c >= 0 and c < w then
      local i = r * w + c
      drop = bit.band(string.byte(bits, math.floor(i / 8) + 1), bit.rshift(128, i % 8)) ~= 0
    end
  end
  if drop then gone[#gone + 1] = all[k] end
end
for i = 1, #gone, 1000 do
  redis.call('HDEL', KEYS[1], unpack(gone, i, math.min(i + 999, #gone)))
end
local lapse = string.format('%.0f', ms + tonumber(ARGV[1]))
local marks = {}
for i = 8, #ARGV do
  marks[#marks + 1] = ARGV[i]
  marks[#marks + 1] = lapse
  if #marks >= 2000 then
    redis.call('HSET', KEYS[1], unpack(marks))
    marks = {}
  end
end
if #marks > 0 then redis.call('HSET', KEYS[1], unpack(marks)) end
local n = redis.call('HLEN', KEYS[1])
if n > 0 and #ARGV > 7 and redis.call('PTTL', KEYS[1]) < tonumber(ARGV[1]) then
  redis.call('PEXPIRE', KEYS[1], ARGV[1])
end
return n
"""
)

# The marks live now, as one string of cells separated by spaces.
LIVE_MARKS = (
    _NOW
    + """
local all = redis.call('HGETALL', KEYS[1])
local out = {}
for k = 1, #all, 2 do
  if tonumber(all[k + 1]) > ms then out[#out + 1] = all[k] end
end
return table.concat(out, ' ')
"""
)


class LiveLayer(ABC):
    """The live layer's methods of :class:`~service.stores.redis.RedisStore`."""

    _reaching: AbstractContextManager[None]
    _observe: Any  # the registered OBSERVE script
    _live_marks: Any  # the registered LIVE_MARKS script

    async def observe(self, map_id: str, seen: Seen) -> int:
        t = seen.traced
        h, w = t.cleared.shape
        bits = np.packbits(t.cleared.reshape(-1)).tobytes()
        ms = max(1, round(seen.seconds * 1000))
        args: list[Any] = [ms, seen.width, t.top, t.left, h, w, bits, *t.marked.tolist()]
        with self._reaching:
            n = await self._observe(keys=[_key(map_id)], args=args)
        return int(n)

    async def live_marks(self, map_id: str) -> npt.NDArray[np.int64]:
        with self._reaching:
            value = await self._live_marks(keys=[_key(map_id)])
        cells = np.array(sorted(map(int, value.split())), dtype=np.int64)
        return cells.reshape(-1)


def _key(map_id: str) -> str:
    return f"planner:live:{scoped(map_id)}"

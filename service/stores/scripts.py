"""The Redis store's Lua scripts: a step and a new plan, each one round trip, each checking
that the plan's map is still there and keeping its tenant's set of live plans."""

from __future__ import annotations

__all__ = ["FLEET_DELETE", "FLEET_PUT", "FLEET_STEP", "LIVE_MARKS", "OBSERVE", "PUT", "STEP"]

# The time in Redis, in milliseconds: what the tenants' sets of plans are scored by.
_NOW = """
local clock = redis.call('TIME')
local ms = tonumber(clock[1]) * 1000 + math.floor(tonumber(clock[2]) / 1000)
"""

# Whether the map (KEYS[4], when the record names one) is still there; restarts its TTL (ARGV
# map_ttl; '0': maps are kept).
_MAP_GONE = """
local function map_gone(map_ttl)
  if not KEYS[4] then return false end
  if map_ttl ~= '0' then return redis.call('PEXPIRE', KEYS[4], map_ttl) == 0 end
  return redis.call('EXISTS', KEYS[4]) == 0
end
"""

# A map's live marks now (docs/live.md; the hash KEYS[live]: cell -> the Redis time, ms, its
# mark lapses): the cells not lapsed, in ascending order, separated by spaces. A step decided on
# the marks this replica last heard (the SHA-1 of that string, ARGV[9]; '': it read none) is
# written only if they are still the map's marks: else it answers them, to decide again on.
_LIVE = """
local function live_marks(key)
  local clock = redis.call('TIME')
  local ms = tonumber(clock[1]) * 1000 + math.floor(tonumber(clock[2]) / 1000)
  local all = redis.call('HGETALL', key)
  local out = {}
  for k = 1, #all, 2 do
    if tonumber(all[k + 1]) > ms then out[#out + 1] = tonumber(all[k]) end
  end
  table.sort(out)
  return table.concat(out, ' ')
end
local function marks_moved(key, digest)
  if digest == nil or digest == '' or not key then return false end
  local marks = live_marks(key)
  if redis.sha1hex(marks) == digest then return false end
  return marks
end
"""

# A step's one round trip: KEYS the plan, its path, its tenant's set of live plans (scored by
# expiry), its map and its map's live marks (when the record names one); ARGV the version
# prefix the step decided on, the new value ('' for none: a replay, only checked), the plan's
# TTL, the cells to append, the map's TTL, the viewer's channel and message ('': none), the
# plan's member in the set, the digest of the marks decided on (see _LIVE).
# Returns {1} (written, or checked), {0} (no such plan: nothing written), {2, value} (another
# step wrote first: the plan's value now, to decide again on), {3} (its map is gone: nothing
# written), {5, marks} (the map's marks moved on: to decide again on). {2, ...} carries the
# map's marks too when they moved on ('' when not). Every write has a version of its own
# (random), so a value already there exactly as this call would write it is this call's own
# write: the same call sent again (the client resends once when an answer is lost) is {1}.
_STEP = (
    _MAP_GONE
    + _LIVE
    + """
local now = redis.call('GET', KEYS[1])
if not now then return {0} end
if ARGV[2] ~= '' and now == ARGV[2] then return {1} end
if string.sub(now, 1, #ARGV[1]) ~= ARGV[1] then
  return {2, now, marks_moved(live_key, ARGV[9]) or ''}
end
if ARGV[2] == '' then return {1} end
local moved_marks = marks_moved(live_key, ARGV[9])
if moved_marks then return {5, moved_marks} end
if map_gone(ARGV[5]) then return {3} end
redis.call('SET', KEYS[1], ARGV[2], 'PX', ARGV[3])
if ARGV[4] ~= '' then redis.call('APPEND', KEYS[2], ARGV[4]) end
redis.call('PEXPIRE', KEYS[2], ARGV[3])
"""
    + _NOW
    + """
redis.call('ZADD', KEYS[3], ms + tonumber(ARGV[3]), ARGV[8])
redis.call('PEXPIRE', KEYS[3], ARGV[3])
if ARGV[6] ~= '' then redis.call('PUBLISH', ARGV[6], ARGV[7]) end
return {1}
"""
)
STEP = "local live_key = KEYS[5]\n" + _STEP

# A new plan (or a replaced one) in one round trip: the same keys; ARGV the value, the TTL, the
# cells, the map's TTL, the tenant's cap of live plans ('0': none) and the plan's member.
# Returns 1 (written), 0 (its map is gone), -n (the tenant holds n plans, its cap): then nothing
# is written. The tenant's expired plans leave its set here.
PUT = (
    _MAP_GONE
    + _NOW
    + """
if map_gone(ARGV[4]) then return 0 end
redis.call('ZREMRANGEBYSCORE', KEYS[3], '-inf', ms)
local held = redis.call('ZCARD', KEYS[3])
if ARGV[5] ~= '0' and held >= tonumber(ARGV[5]) and not redis.call('ZSCORE', KEYS[3], ARGV[6])
then return -held end
redis.call('SET', KEYS[1], ARGV[1], 'PX', ARGV[2])
if ARGV[3] ~= '' then redis.call('APPEND', KEYS[2], ARGV[3]) end
redis.call('PEXPIRE', KEYS[2], ARGV[2])
redis.call('ZADD', KEYS[3], ms + tonumber(ARGV[2]), ARGV[6])
redis.call('PEXPIRE', KEYS[3], ARGV[2])
return 1
"""
)


# A fleet is two keys: its record (KEYS[5], version-prefixed JSON: the joint plan, a snapshot of
# every robot's progress) and its robots' progress (KEYS[6], a hash: robot -> JSON, the fields
# its own steps change). A fleet script's ARGV, from index ``e``: the record's version prefix
# decided on ('': there was no fleet), its new value ('': unchanged), then three counted lists:
# the progress to write (robot, JSON), the robots gone, and the fence (robot, moves told as the
# decision read them; a robot told more since fails it). Every fleet script answers
# {code, plan, fleet, progress, time}: the plan's value (code 2) and the fleet record's (code 4:
# it moved on, or a fenced robot was told more) to decide again on, else '', the progress hash,
# and Redis's time (microseconds) when it was read: a replica keeps only the latest it heard.
def _fleet(e: int) -> str:
    return f"""
local fleet_at = {e}
local progress = function() return redis.call('HGETALL', KEYS[6]) end
local function now_us()
  local t = redis.call('TIME')
  return tonumber(t[1]) * 1000000 + tonumber(t[2])
end
local function fleet_moved()
  local fleet = redis.call('GET', KEYS[5])
  local prefix = ARGV[fleet_at]
  if prefix == '' then
    if fleet then return fleet end
  elseif not fleet then return ''
  elseif string.sub(fleet, 1, #prefix) ~= prefix then return fleet end
  local at = fleet_at + 2
  local n = tonumber(ARGV[at]); at = at + 1 + 2 * n
  n = tonumber(ARGV[at]); at = at + 1 + n
  n = tonumber(ARGV[at])
  for i = 1, n do
    local was = redis.call('HGET', KEYS[6], ARGV[at + 2 * i - 1])
    if was and (cjson.decode(was)['told'] or 0) ~= tonumber(ARGV[at + 2 * i]) then return fleet end
  end
  return false
end
local function write_fleet(ttl)
  if ARGV[fleet_at + 1] ~= '' then redis.call('SET', KEYS[5], ARGV[fleet_at + 1], 'PX', ttl)
  else redis.call('PEXPIRE', KEYS[5], ttl) end
  local at = fleet_at + 2
  local n = tonumber(ARGV[at])
  for i = 1, n do redis.call('HSET', KEYS[6], ARGV[at + 2 * i - 1], ARGV[at + 2 * i]) end
  at = at + 1 + 2 * n
  n = tonumber(ARGV[at])
  for i = 1, n do redis.call('HDEL', KEYS[6], ARGV[at + i]) end
  redis.call('PEXPIRE', KEYS[6], ttl)
end
"""


def _edit(script: str, old: str, new: str) -> str:
    """``script`` with ``old`` (present exactly once) replaced."""
    if script.count(old) != 1:
        raise AssertionError(f"{old!r} is not in the script once")
    return script.replace(old, new)


# A fleet robot's step in one round trip: STEP's keys and arguments, then the fleet's keys
# (KEYS[5], KEYS[6]) and its map's marks (KEYS[7]), and the fleet's arguments (from ARGV[10]).
# Codes as STEP's, and 4; {5, marks, '', progress, time} when the marks moved on.
FLEET_STEP = (
    "local live_key = KEYS[7]\n"
    + _fleet(10)
    + _edit(
        _edit(
            _edit(
                _edit(
                    _edit(
                        _edit(
                            _STEP,
                            "if moved_marks then return {5, moved_marks} end",
                            "if moved_marks then\n"
                            "  return {5, moved_marks, '', progress(), now_us()}\nend",
                        ),
                        "if not now then return {0} end",
                        "if not now then return {0, '', '', {}} end",
                    ),
                    "if ARGV[2] ~= '' and now == ARGV[2] then return {1} end",
                    "if ARGV[2] ~= '' and now == ARGV[2] then\n"
                    "  return {1, '', '', progress(), now_us()}\nend",
                ),
                "  return {2, now, marks_moved(live_key, ARGV[9]) or ''}\nend\n"
                "if ARGV[2] == '' then return {1} end\n",
                "  local marks = marks_moved(live_key, ARGV[9]) or ''\n"
                "  return {2, now, fleet_moved() or '', progress(), now_us(), marks}\nend\n"
                "if ARGV[2] == '' then return {1, '', '', progress(), now_us()} end\n"
                "local moved = fleet_moved()\n"
                "if moved then return {4, '', moved, progress(), now_us()} end\n",
            ),
            "if map_gone(ARGV[5]) then return {3} end",
            "if map_gone(ARGV[5]) then return {3, '', '', {}} end",
        ),
        "return {1}\n",
        "write_fleet(ARGV[3])\nreturn {1, '', '', progress(), now_us()}\n",
    )
)

# A new plan of a fleet, joining it: PUT's keys and arguments, then the fleet's (from ARGV[7]).
# Its code: PUT's answer, or 4.
FLEET_PUT = _fleet(7) + _edit(
    _edit(
        _edit(
            PUT,
            "if map_gone(ARGV[4]) then return 0 end",
            "local moved = fleet_moved()\n"
            "if moved then return {4, '', moved, progress(), now_us()} end\n"
            "if map_gone(ARGV[4]) then return {0, '', '', {}} end",
        ),
        "then return -held end",
        "then return {-held, '', '', {}} end",
    ),
    "return 1\n",
    "write_fleet(ARGV[2])\nreturn {1, '', '', progress(), now_us()}\n",
)

# A fleet's plan deleted, leaving it: KEYS the plan, its path, its tenant's plans, (unused), the
# fleet's two keys; ARGV[1] the plan's member in its tenant's set, then the fleet's (from
# ARGV[2]; its new value '': the fleet goes with its last robot). {1, deleted keys} or code 4.
FLEET_DELETE = (
    _fleet(2)
    + """
local moved = fleet_moved()
if moved then return {4, '', moved, progress(), now_us()} end
local gone = redis.call('DEL', KEYS[1], KEYS[2])
redis.call('ZREM', KEYS[3], ARGV[1])
if ARGV[3] == '' then redis.call('DEL', KEYS[5], KEYS[6])
else
  redis.call('SET', KEYS[5], ARGV[3], 'KEEPTTL')
  local at = 4
  local n = tonumber(ARGV[at]); at = at + 1 + 2 * n
  n = tonumber(ARGV[at])
  for i = 1, n do redis.call('HDEL', KEYS[6], ARGV[at + i]) end
end
return {1, gone}
"""
)


# A scan's update in one round trip: KEYS the map's marks; ARGV how long a mark lasts (ms), the
# map's width, the cleared window's top, left, height and width, its cells as bits (row-major,
# the first cell the high bit of the first byte), then the marked cells. Marks lapsed or
# cleared go, the scan's are (re)marked; the key lasts as long as its last mark. Returns how
# many marks the map has now, and them (as LIVE_MARKS answers them).
OBSERVE = (
    _NOW
    + _LIVE
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
return {n, live_marks(KEYS[1])}
"""
)

# The map's marks live now (KEYS[1]), as _LIVE writes them.
LIVE_MARKS = _LIVE + "\nreturn live_marks(KEYS[1])\n"

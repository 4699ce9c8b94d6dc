"""The Redis store's Lua scripts: a step and a new plan, each one round trip, each checking
that the plan's map is still there and keeping its tenant's set of live plans."""

from __future__ import annotations

__all__ = ["FLEET_DELETE", "FLEET_PUT", "FLEET_STEP", "PUT", "STEP"]

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

# A step's one round trip: KEYS the plan, its path, its tenant's set of live plans (scored by
# expiry) and its map (when the record names one); ARGV the version prefix the step decided
# on, the new value ('' for none: a replay, only checked), the plan's TTL, the cells to append,
# the map's TTL, the viewer's channel and message ('': none), the plan's member in the set.
# Returns {1} (written, or checked), {0} (no such plan: nothing written), {2, value} (another
# step wrote first: the plan's value now, to decide again on), {3} (its map is gone: nothing
# written). Every write has a version of its own (random), so a value already there exactly as
# this call would write it is this call's own write: the same call sent again (the client
# resends once when an answer is lost) is {1}.
STEP = (
    _MAP_GONE
    + """
local now = redis.call('GET', KEYS[1])
if not now then return {0} end
if ARGV[2] ~= '' and now == ARGV[2] then return {1} end
if string.sub(now, 1, #ARGV[1]) ~= ARGV[1] then return {2, now} end
if ARGV[2] == '' then return {1} end
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


# The fleet's version check, shared by the fleet scripts: KEYS[5] the fleet, ARGV[e] the version
# prefix decided on ('': there was no fleet). Returns {4, value} ('' for none) when it moved on.
def _fence(e: int) -> str:
    return f"""
local fleet = redis.call('GET', KEYS[5])
if ARGV[{e}] == '' then
  if fleet then return {{4, fleet}} end
elseif not fleet then return {{4, ''}}
elseif string.sub(fleet, 1, #ARGV[{e}]) ~= ARGV[{e}] then return {{4, fleet}} end
"""


def _edit(script: str, old: str, new: str) -> str:
    """``script`` with ``old`` (present exactly once) replaced."""
    if script.count(old) != 1:
        raise AssertionError(f"{old!r} is not in the script once")
    return script.replace(old, new)


# A fleet robot's step in one round trip: STEP's keys (the plan, its path, its tenant's plans,
# its map) and arguments, then KEYS[5] the fleet, ARGV[9] the fleet's version prefix decided
# on, ARGV[10] its new value. Besides STEP's answers, {4, value}: another robot of the fleet was
# recorded first (the fleet's value now, to decide again on).
_WRITE_FLEET = "redis.call('SET', KEYS[5], ARGV[10], 'PX', ARGV[3])\n"
FLEET_STEP = _edit(
    _edit(STEP, "if map_gone(ARGV[5])", _fence(9) + "if map_gone(ARGV[5])"),
    "if ARGV[6] ~= '' then",
    _WRITE_FLEET + "if ARGV[6] ~= '' then",
)

# A new plan of a fleet, joining it: PUT's keys and arguments, then KEYS[5] the fleet, ARGV[7]
# the fleet's version prefix, ARGV[8] its new value; PUT's answers as {answer}, or {4, value}.
FLEET_PUT = _fence(7) + _edit(
    _edit(
        _edit(PUT, "then return 0 end", "then return {0} end"),
        "then return -held end",
        "then return {-held} end",
    ),
    "return 1\n",
    "redis.call('SET', KEYS[5], ARGV[8], 'PX', ARGV[2])\nreturn {1}\n",
)

# A fleet's plan deleted, leaving it: KEYS the plan, its path, its tenant's plans, (unused), the
# fleet; ARGV[1] the fleet's version prefix, ARGV[2] its new value ('': the fleet goes with its
# last robot), ARGV[3] the plan's member in its tenant's set. {1, deleted keys}, or {4, value}.
FLEET_DELETE = (
    _fence(1)
    + """
local gone = redis.call('DEL', KEYS[1], KEYS[2])
redis.call('ZREM', KEYS[3], ARGV[3])
if ARGV[2] == '' then redis.call('DEL', KEYS[5])
else redis.call('SET', KEYS[5], ARGV[2], 'KEEPTTL') end
return {1, gone}
"""
)

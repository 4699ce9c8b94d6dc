"""The ``Store`` interface every store of maps and plans implements, and the formats they keep:
a plan as a JSON record of constant size beside an append-only trajectory log, so a networked
store can hold it and a step costs the same at any length of episode."""

from __future__ import annotations

import asyncio
import math
import struct
from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np
import numpy.typing as npt
import orjson

from planner import MapFrame, RobotMap, Zones, quote
from service.errors import NotFound, TooManyPlans
from service.stores.live import Marks, Seen

__all__ = [
    "Cells",
    "Decide",
    "Event",
    "FleetDecide",
    "FleetJoin",
    "FleetRecord",
    "Grid",
    "PlanLocks",
    "PlanRecord",
    "Store",
    "Update",
    "decode_map",
    "encode_map",
    "live_fleet",
    "pack",
    "stamp_robot",
    "too_many_plans",
    "unknown_map",
    "unpack",
]

Grid = npt.NDArray[np.uint8]
PlanRecord = dict[str, Any]
FleetRecord = dict[str, Any]
"""A fleet's shared state (docs/fleets.md): ``{"map_id", "radius", "params", "next", "dirty",
"solve", "robots": {plan_id: robot}, ...}``, each robot its goal, progress and moves, as
:mod:`service.resources.fleets` writes them."""
Cells = Sequence[Sequence[int]]
Event = tuple[str, bytes]
"""A message for the live viewer: its pub/sub channel and its bytes."""
T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class Update(Generic[T]):
    """What a step decided from a plan's record: its ``answer`` (handed back by
    :meth:`Store.update_plan`) and what to write: the new ``record`` (None: nothing, a retried
    ``seq``), the cells to ``append`` to the trajectory and the viewer's ``event``."""

    answer: T
    record: PlanRecord | None = None
    append: Cells = ()
    event: Event | None = None
    fleet: FleetRecord | None = None
    """A fleet robot's step: its fleet's new state, written with the record (or not at all)."""
    marks: str = ""
    """The digest of the live marks the decision stood on (:meth:`Store.known_marks`): written
    only if they are still the map's marks (else decided again on them)."""


Decide = Callable[[PlanRecord], Awaitable[Update[T]]]
"""A step's decision from the plan's current record; it may run again on a newer record (a
networked store whose write found another replica's step first), so it changes nothing else."""
FleetDecide = Callable[[PlanRecord, FleetRecord | None], Awaitable[Update[T]]]
"""A step's decision from the plan's record and, for a fleet robot, its fleet's state (its
live robots only); it may run again on a newer record or fleet state."""
FleetJoin = Callable[[FleetRecord | None], FleetRecord]
"""A plan joining its fleet: the fleet's new state from its current one (None: a new fleet), or
an error (then nothing is written)."""


def live_fleet(fleet: FleetRecord | None, now: float) -> FleetRecord | None:
    """The fleet without its robots whose plans expired (``until`` passed): a networked store
    expires a plan without touching its fleet."""
    if fleet is None:
        return None
    robots = fleet["robots"]
    gone = [k for k, robot in robots.items() if (robot.get("until") or math.inf) <= now]
    if not gone:
        return fleet
    robots = {k: v for k, v in robots.items() if k not in gone}
    return {**fleet, "robots": robots, "dirty": True}


def stamp_robot(fleet: FleetRecord, plan_id: str, until: float) -> FleetRecord:
    """The fleet with ``plan_id``'s robot expiring at ``until`` (with its plan, just written)."""
    robot = fleet["robots"].get(plan_id)
    if robot is None:
        return fleet
    return {**fleet, "robots": {**fleet["robots"], plan_id: {**robot, "until": until}}}


class PlanLocks:
    """One FIFO ``asyncio.Lock`` a plan, made when a step comes and dropped when none holds or
    waits for it: steps on one plan in this process are served one at a time, in arrival order.
    ``async with locks.hold(key):`` (a class, not a generator: it is entered on every step)."""

    def __init__(self) -> None:
        self._locks: dict[str, tuple[asyncio.Lock, int]] = {}  # lock, steps holding or waiting

    def hold(self, key: str) -> _Held:
        return _Held(self._locks, key)

    def __len__(self) -> int:
        return len(self._locks)


class _Held:
    """A step's turn on its plan's lock (:meth:`PlanLocks.hold`)."""

    __slots__ = ("_key", "_lock", "_locks")

    def __init__(self, locks: dict[str, tuple[asyncio.Lock, int]], key: str) -> None:
        self._locks, self._key = locks, key

    async def __aenter__(self) -> None:
        lock, users = self._locks.get(self._key, (None, 0))
        if lock is None:
            lock = asyncio.Lock()
        self._locks[self._key] = (lock, users + 1)
        self._lock = lock
        try:
            await lock.acquire()
        except BaseException:  # cancelled while waiting: no longer a user
            self._leave()
            raise

    async def __aexit__(self, *exc: object) -> None:
        self._lock.release()
        self._leave()

    def _leave(self) -> None:
        lock, users = self._locks[self._key]
        if users == 1:
            del self._locks[self._key]
        else:
            self._locks[self._key] = (lock, users - 1)


def unknown_map(map_id: str) -> NotFound:
    """No map ``map_id`` in the store: never uploaded with this key, or forgotten since."""
    msg = (
        f"map_id: no map {quote(map_id)} (unknown, or forgotten: unused for "
        "PLANNER_MAP_TTL_SECONDS, or evicted); upload it with POST /maps"
    )
    return NotFound(msg, field="map_id")


def too_many_plans(held: int) -> TooManyPlans:
    """The tenant holds its ``PLANNER_MAX_PLANS_PER_TENANT`` live plans already."""
    msg = (
        f"this key has {held} live plans (PLANNER_MAX_PLANS_PER_TENANT); delete plans "
        "(DELETE /plan/{plan_id}) or wait for them to expire"
    )
    return TooManyPlans(msg)


def pack(cells: Cells) -> bytes:
    """Cells as little-endian int32 pairs: the trajectory log's format, in every store."""
    flat = [v for cell in cells for v in cell]
    if len(flat) != 2 * len(cells):
        raise ValueError(f"cells must be [row, col] pairs; got {len(flat)} values")
    return struct.pack(f"<{len(flat)}i", *flat)


def unpack(data: bytes) -> list[tuple[int, int]]:
    """The cells of a trajectory log, in order."""
    return list(map(tuple, np.frombuffer(data, dtype="<i4").reshape(-1, 2).tolist()))


MAP_MAGIC = b"occ1 "


def encode_map(robot_map: RobotMap) -> bytes:
    """A map as bytes: ``b"occ1 {H}x{W} {resolution} {ox} {oy} {yaw}:"`` (floats as ``repr``,
    exact) then the occupancy, one int8 a cell, row 0 (the top) first; a zoned map's zones
    after the cells, as JSON (:meth:`planner.Zones.as_dict`)."""
    (h, w), res, (ox, oy, yaw) = robot_map.shape, robot_map.resolution, robot_map.origin
    head = f"{h}x{w} {res!r} {ox!r} {oy!r} {yaw!r}:".encode()
    data = MAP_MAGIC + head + robot_map.occupancy.tobytes()
    if robot_map.zones is not None:
        data += orjson.dumps(robot_map.zones.as_dict())
    return data


def decode_map(data: bytes) -> RobotMap:
    """:func:`encode_map`'s map back (read-only); also reads the older ``b"{H}x{W}:"`` + 0/1
    cells of plain grids."""
    if not data.startswith(MAP_MAGIC):
        shape, _, cells = data.partition(b":")
        h, w = (int(n) for n in shape.split(b"x"))
        grid = np.frombuffer(cells, dtype=np.uint8).reshape(h, w)
        occupancy = (grid * np.uint8(100)).astype(np.int8)
        return RobotMap(occupancy, MapFrame((h, w)))
    head, _, cells = data[len(MAP_MAGIC) :].partition(b":")
    size, res, ox, oy, yaw = head.decode().split(" ")
    h, w = (int(n) for n in size.split("x"))
    occupancy = np.frombuffer(cells, dtype=np.int8, count=h * w).reshape(h, w)
    zones = Zones.from_dict(orjson.loads(cells[h * w :])) if len(cells) > h * w else None
    frame = MapFrame((h, w), float(res), (float(ox), float(oy), float(yaw)))
    return RobotMap(occupancy, frame, zones)


class Store(ABC):
    """Maps by ``map_id`` (kept) and plans by ``plan_id`` (forgotten after a TTL).

    A store that cannot answer raises :class:`service.errors.StoreUnavailable`, never its
    client's own errors.
    """

    kind: str
    publishes = False
    """Whether :meth:`update_plan` publishes an update's ``event`` (else the caller does)."""

    @abstractmethod
    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        """Keep a map (occupancy, resolution, origin); True when it was not known before."""

    @abstractmethod
    async def get_map(self, map_id: str) -> RobotMap | None:
        """The map (read-only), or None."""

    @abstractmethod
    async def has_map(self, map_id: str) -> bool:
        """Whether the store holds the map now (a use of it: restarts its TTL)."""

    @abstractmethod
    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        """Keep (or replace) a plan's record and add ``append`` to its trajectory, both at once;
        restarts the plan's TTL (and its map's). Refused, with nothing written, when the
        record's map is not in the store (:func:`unknown_map`) or when the tenant holds its
        cap of live plans already (:func:`too_many_plans`)."""

    @abstractmethod
    async def update_plan(self, plan_id: str, decide: Decide[T]) -> Update[T] | None:
        """Step a plan: ``decide`` on its current record, then write the :class:`Update` it
        answers (record, appended cells, and the ``event`` published with the write by a store
        that :attr:`publishes`), all at once, restarting the plan's TTL and its map's. Steps on
        one plan never interleave: none loses or doubles a move. None when the plan does not
        exist or was deleted before the write (then nothing is written or published); errors of
        ``decide`` propagate, with nothing written; the record's map gone from the store is
        :func:`unknown_map`, with nothing written. ``decide`` reads the record it is given and
        changes nothing in it (a store may hand it the record it keeps)."""

    @abstractmethod
    async def step_plan(self, plan_id: str, decide: FleetDecide[T]) -> Update[T] | None:
        """:meth:`update_plan` for any plan: ``decide`` also gets the state of the plan's fleet
        (the record's ``fleet``; None for a plan of no fleet) and its ``Update.fleet`` is
        written with the record, all at once: no two steps of one fleet decide on the same
        fleet state and both write (one of them decides again on the other's)."""

    @abstractmethod
    async def put_fleet_plan(
        self, plan_id: str, record: PlanRecord, join: FleetJoin, *, append: Cells = ()
    ) -> None:
        """:meth:`put_plan` for a plan of the fleet ``record["fleet"]``: ``join`` makes the
        fleet's new state from its current one (None: a new fleet) or raises (nothing is
        written); both are written at once."""

    @abstractmethod
    async def get_fleet(self, fleet: str) -> FleetRecord | None:
        """The fleet's state (its live robots), or None when it has none."""

    @abstractmethod
    async def observe(self, map_id: str, seen: Seen) -> int:
        """A scan's update of the map's live layer (docs/live.md), at once: marks whose time
        passed and those the scan's rays cleared go, its returns' cells are marked for
        ``seen.seconds``. Answers how many marks the map has now."""

    @abstractmethod
    async def live_marks(self, map_id: str) -> npt.NDArray[np.int64]:
        """The map's live marks now: flat cell indices, sorted (none: an empty array)."""

    @abstractmethod
    async def known_marks(self, map_id: str) -> Marks:
        """The map's live marks for a step to decide on, at no round trip: a networked store's
        as it last heard them, which the step's write checks (``Update.marks``)."""

    @abstractmethod
    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        """A copy of the plan's record, or None when unknown, deleted or expired."""

    @abstractmethod
    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        """Every cell appended to the plan's trajectory, in order (none for an unknown plan)."""

    @abstractmethod
    async def delete_plan(self, plan_id: str) -> bool:
        """Forget a plan (and its robot in its fleet, at once); True when it existed."""

    @abstractmethod
    async def counts(self) -> tuple[int, int]:
        """How many maps and how many live plans the store holds (for ``/metrics``)."""

    async def check(self) -> str | None:
        """None when the store answers, else why it does not (for ``/healthz``)."""
        return None

    async def close(self) -> None:  # noqa: B027 - a store with nothing to release keeps this
        """Release connections."""

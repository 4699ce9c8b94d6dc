"""The ``Store`` interface that every store of maps and plans implements, and its data formats.

A plan is kept as plain JSON data (its inputs and ``SessionState.as_dict()`` less the
trajectory), never as arrays, so a networked store (``service/stores/redis.py``) can hold it; the
arrays are rebuilt from the cached analysis and wave. The trajectory, which grows with every
move, is kept beside the record as an append-only log of packed cells: a step rewrites a record
of constant size and appends a cell, whatever the length of the episode.

Ids are kept per tenant (:func:`service.edge.tenants.scoped`): every store prefixes the map and plan
ids it is given with the current request's tenant, so tenants never see each other's data.

A step runs inside :meth:`Store.plan_lock`, which yields the plan's record read under the lock
(None, and no lock taken, for a plan that does not exist), and writes back with
``put_plan(..., existing=True)``: a write that finds the plan deleted meanwhile writes nothing,
so a plan deleted while a step was in flight stays deleted.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from contextlib import AbstractAsyncContextManager
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.robot_maps import MapFrame, RobotMap

__all__ = [
    "Cells",
    "Event",
    "Grid",
    "PlanRecord",
    "Store",
    "decode_map",
    "encode_map",
    "pack",
    "unpack",
]

Grid = npt.NDArray[np.uint8]
PlanRecord = dict[str, Any]
Cells = Sequence[Sequence[int]]
Event = tuple[str, bytes]
"""A message for the live viewer: its pub/sub channel and its bytes."""


def pack(cells: Cells) -> bytes:
    """Cells as little-endian int32 pairs: the trajectory log's format, in every store."""
    return np.asarray(cells, dtype="<i4").reshape(-1, 2).tobytes()


def unpack(data: bytes) -> list[tuple[int, int]]:
    """The cells of a trajectory log, in order."""
    return list(map(tuple, np.frombuffer(data, dtype="<i4").reshape(-1, 2).tolist()))


MAP_MAGIC = b"occ1 "


def encode_map(robot_map: RobotMap) -> bytes:
    """A map as bytes: ``b"occ1 {H}x{W} {resolution} {ox} {oy} {yaw}:"`` (floats as ``repr``,
    exact) then the occupancy, one int8 a cell, row 0 (the top) first."""
    (h, w), res, (ox, oy, yaw) = robot_map.shape, robot_map.resolution, robot_map.origin
    head = f"{h}x{w} {res!r} {ox!r} {oy!r} {yaw!r}:".encode()
    return MAP_MAGIC + head + robot_map.occupancy.tobytes()


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
    occupancy = np.frombuffer(cells, dtype=np.int8).reshape(h, w)
    return RobotMap(occupancy, MapFrame((h, w), float(res), (float(ox), float(oy), float(yaw))))


class Store(ABC):
    """Maps by ``map_id`` (kept) and plans by ``plan_id`` (forgotten after a TTL).

    A store that cannot answer raises :class:`service.errors.StoreUnavailable`, never its
    client's own errors.
    """

    kind: str
    publishes = False
    """Whether :meth:`put_plan` publishes its ``event`` (else the caller publishes it)."""

    @abstractmethod
    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        """Keep a map (occupancy, resolution, origin); True when it was not known before."""

    @abstractmethod
    async def get_map(self, map_id: str) -> RobotMap | None:
        """The map (read-only), or None."""

    @abstractmethod
    async def put_plan(
        self,
        plan_id: str,
        record: PlanRecord,
        *,
        append: Cells = (),
        existing: bool = False,
        event: Event | None = None,
    ) -> bool:
        """Keep (or replace) a plan's record and add ``append`` to its trajectory, both at once;
        restarts the plan's TTL (and its map's). With ``existing``, only a plan that still
        exists is written: False when it was deleted or expired (nothing written then).
        ``event``, a ``(channel, message)`` for the live viewer, is published with the write by a
        store that can (Redis: in the same round trip) when the write happens; others ignore it
        (see :attr:`publishes`)."""

    @abstractmethod
    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        """A copy of the plan's record, or None when unknown, deleted or expired."""

    @abstractmethod
    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        """Every cell appended to the plan's trajectory, in order (none for an unknown plan)."""

    @abstractmethod
    async def delete_plan(self, plan_id: str) -> bool:
        """Forget a plan; True when it existed."""

    @abstractmethod
    def plan_lock(self, plan_id: str) -> AbstractAsyncContextManager[PlanRecord | None]:
        """An async context manager held while a plan is read, stepped and written back; it
        yields the plan's record, or None (holding nothing) when the plan does not exist."""

    @abstractmethod
    async def counts(self) -> tuple[int, int]:
        """How many maps and how many live plans the store holds (for ``/metrics``)."""

    async def check(self) -> str | None:
        """None when the store answers, else why it does not (for ``/healthz``)."""
        return None

    async def close(self) -> None:  # noqa: B027 - a store with nothing to release keeps this
        """Release connections."""

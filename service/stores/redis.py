"""The Redis store: maps and plans shared by every replica, through redis-py.

Keys live under ``planner:`` (``map:``, ``plan:``, ``path:``, ``fleet:``, ``live:``); a step is
one version-fenced script call, so no lock is held in Redis. The store is its parts, each a job:
the plans (:mod:`~service.stores.redis_plans`), the fleets (:mod:`~service.stores.redis_fleets`)
and the live layer (:mod:`~service.stores.redis_live`), sharing one client
(:mod:`~service.stores.redis_link`). Design: docs/redis-store.md.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import orjson

from planner import RobotMap
from service.errors import StoreUnavailable
from service.stores.base import (
    Cells,
    Decide,
    FleetDecide,
    FleetJoin,
    FleetRecord,
    PlanRecord,
    Store,
    T,
    Update,
    decode_map,
    encode_map,
    unpack,
)
from service.stores.live import Marks, Seen
from service.stores.redis_fleets import FleetSteps
from service.stores.redis_link import RedisLink
from service.stores.redis_live import LiveMarks
from service.stores.redis_plans import PlanCopies
from service.stores.redis_values import plans_of, split
from service.tenants import scoped

__all__ = ["RedisStore"]


class RedisStore(Store):
    """Maps and plans in Redis, for any number of replicas.

    A step decides on the record this replica last read or wrote (and on the map's live marks
    as it last heard them), then one script writes it only if the plan's version (and the
    marks) are still the ones decided on; when another replica wrote first it decides again on
    what the script answers. Every write has a version of its own, so a call redis-py resends
    after a lost answer finds its own write. Steps on one plan in this process take turns.
    """

    kind = "redis"
    publishes = True

    def __init__(
        self,
        url: str,
        *,
        ttl_seconds: float,
        map_ttl_seconds: float = 0,
        max_plans: int | None = None,
    ) -> None:
        self._link = RedisLink(
            url, ttl_seconds=ttl_seconds, map_ttl_seconds=map_ttl_seconds, max_plans=max_plans
        )
        self._redis = self._link.redis
        self.address = self._link.address
        self._live = LiveMarks(self._link)
        self.plans = PlanCopies(self._link, self._live)
        self.fleets = FleetSteps(self._link, self.plans)

    async def put_map(self, map_id: str, robot_map: RobotMap) -> bool:
        key = f"planner:map:{scoped(map_id)}"
        value, ttl = encode_map(robot_map), self._link.map_ttl_ms
        with self._link.reaching:
            if ttl:
                async with self._redis.pipeline(transaction=True) as pipe:
                    pipe.set(key, value, nx=True, px=ttl)
                    pipe.pexpire(key, ttl)
                    created, _ = await pipe.execute()
            else:
                created = await self._redis.set(key, value, nx=True)
        return bool(created)

    async def get_map(self, map_id: str) -> RobotMap | None:
        key = f"planner:map:{scoped(map_id)}"
        with self._link.reaching:
            if self._link.map_ttl_ms:
                value = await self._redis.getex(key, px=self._link.map_ttl_ms)
            else:
                value = await self._redis.get(key)
        if value is None:
            return None
        assert isinstance(value, bytes)  # no decode_responses
        return decode_map(value)

    async def has_map(self, map_id: str) -> bool:
        key = f"planner:map:{scoped(map_id)}"
        with self._link.reaching:
            if self._link.map_ttl_ms:
                return bool(await self._redis.pexpire(key, self._link.map_ttl_ms))
            return bool(await self._redis.exists(key))

    async def put_plan(self, plan_id: str, record: PlanRecord, *, append: Cells = ()) -> None:
        await self.plans.put(plan_id, record, append=append)

    async def update_plan(self, plan_id: str, decide: Decide[T]) -> Update[T] | None:
        return await self.plans.update(plan_id, decide)

    async def step_plan(self, plan_id: str, decide: FleetDecide[T]) -> Update[T] | None:
        return await self.fleets.step_plan(plan_id, decide)

    async def put_fleet_plan(
        self, plan_id: str, record: PlanRecord, join: FleetJoin, *, append: Cells = ()
    ) -> None:
        await self.fleets.put_fleet_plan(plan_id, record, join, append=append)

    async def get_fleet(self, fleet: str) -> FleetRecord | None:
        return await self.fleets.get_fleet(fleet)

    async def observe(self, map_id: str, seen: Seen) -> int:
        return await self._live.observe(map_id, seen)

    async def live_marks(self, map_id: str) -> npt.NDArray[np.int64]:
        return await self._live.live_marks(map_id)

    async def known_marks(self, map_id: str) -> Marks:
        return self._live.known(map_id)

    async def get_plan(self, plan_id: str) -> PlanRecord | None:
        value = await self._link.get(f"planner:plan:{scoped(plan_id)}")
        return None if value is None else dict(orjson.loads(split(value)[1]))

    async def get_trajectory(self, plan_id: str) -> list[tuple[int, int]]:
        return unpack(await self._link.get(f"planner:path:{scoped(plan_id)}") or b"")

    async def delete_plan(self, plan_id: str) -> bool:
        key = scoped(plan_id)
        value = await self._link.get(f"planner:plan:{key}")
        fleet = None if value is None else orjson.loads(split(value)[1]).get("fleet")
        if fleet is not None:
            return await self.fleets.leave(plan_id, key, scoped(fleet))
        with self._link.reaching:
            async with self._redis.pipeline(transaction=True) as pipe:
                pipe.delete(f"planner:plan:{key}", f"planner:path:{key}")
                pipe.zrem(plans_of(), key)
                gone, _ = await pipe.execute()
        self.plans.copies.pop(key, None)
        return bool(gone)

    @property
    def lock_count(self) -> int:
        """Plans with steps in progress or waiting on this replica (for tests)."""
        return len(self.plans.locks)

    async def counts(self) -> tuple[int, int]:
        # SCAN, not KEYS: it never blocks Redis for long. Expired plans are not listed.
        with self._link.reaching:
            found = [
                sum([1 async for _ in self._redis.scan_iter(match=f"planner:{kind}:*", count=1000)])
                for kind in ("map", "plan")
            ]
        return found[0], found[1]

    async def check(self) -> str | None:
        try:
            with self._link.reaching:
                await self._redis.ping()
        except StoreUnavailable as exc:
            return exc.message
        return None

    async def close(self) -> None:
        await self.plans.steps.close()
        await self.fleets.steps.close()
        await self._redis.aclose()

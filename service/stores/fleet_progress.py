"""A fleet's state in two parts, as the Redis store keeps it (docs/redis-store.md): its record
(the joint plan, the robots' goals and moves: written when the fleet changes, with a snapshot of
every robot's progress) and each robot's progress (the fields its own steps change: written by
that robot's step alone, beside the record, without outdating the other robots' steps; laid
over the record's snapshot when read)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import orjson

from service.stores.base import FleetRecord

__all__ = ["PROGRESS", "FleetWrite", "Progress", "changes"]

PROGRESS = frozenset(
    {
        "done",
        "told",
        "seen",
        "status",
        "waiting_for",
        "cell",
        "previous",
        "held",
        "arrived",
        "until",
    }
)
"""A robot's fields that its own steps change (every step, or nearly): its progress."""


@dataclass(frozen=True, slots=True)
class FleetWrite:
    """What a decision changed in a fleet: its new ``record`` (None when only progress
    changed), the robots whose progress to write, the robots ``gone``, and ``told``: the other
    robots' moves told as the decision read them, which the write checks are still so (a
    robot told more since may be on its way to a node the new state gives another)."""

    record: FleetRecord | None
    progress: dict[str, dict[str, Any]]
    gone: list[str] = field(default_factory=list)
    told: dict[str, int] = field(default_factory=dict)


def changes(old: FleetRecord | None, new: FleetRecord, plan_id: str | None) -> FleetWrite:
    """What to write of ``new``, decided from ``old`` (both whole states) by the step of
    ``plan_id``'s robot (None: no robot's): the record when anything but progress changed
    (with every other robot's ``told`` fenced), else only the progress that changed."""
    before = {} if old is None else old["robots"]
    changed = old is None or any(
        new.get(k) is not old.get(k) and new.get(k) != old.get(k)
        for k in new.keys() | old.keys()
        if k != "robots"
    )
    progress: dict[str, dict[str, Any]] = {}
    for k, robot in new["robots"].items():
        was = before.get(k)
        if robot is was:
            continue
        keys = robot.keys() | (() if was is None else was.keys())
        if was is None or any(robot.get(f) != was.get(f) for f in keys - PROGRESS):
            changed = True
        if was is None or any(robot.get(f) != was.get(f) for f in PROGRESS):
            progress[k] = {f: robot[f] for f in PROGRESS if f in robot}
    gone = [k for k in before if k not in new["robots"]]
    if not (changed or gone):
        # The robots whose moves told the decision read: those whose progress it writes, and
        # those the joint plan does not order against the stepping robot (it kept clear of
        # wherever their told moves may have brought them).
        read = set(progress) | _unordered(old, plan_id)
        told = {k: int(before[k].get("told", 0)) for k in read if k != plan_id and k in before}
        return FleetWrite(None, progress, [], told)
    told = {k: int(robot.get("told", 0)) for k, robot in before.items() if k != plan_id}
    return FleetWrite(new, progress, gone, told)


def _unordered(state: FleetRecord | None, plan_id: str | None) -> set[str]:
    """The robots the fleet's joint plan does not order against ``plan_id``'s: every other one
    when it is outside the plan, else the parked ones and those outside the plan."""
    if state is None or plan_id is None:
        return set()
    robots = state["robots"]
    agents = set(state.get("agents", ()))
    me = robots.get(plan_id)
    if me is None or plan_id not in agents or me.get("agent", -1) < 0:
        return set(robots)
    return {k for k, r in robots.items() if k not in agents or r.get("parked")}


class Progress:
    """A fleet's robots' progress as this replica last read it (each robot's JSON, and parsed:
    only the entries that changed are parsed again), and laid over the fleet's record."""

    __slots__ = ("_at", "_merged", "_raw", "_record", "robots")

    def __init__(self) -> None:
        self._at = 0
        self._raw: dict[bytes, bytes] = {}
        self.robots: dict[str, dict[str, Any]] = {}
        self._record: FleetRecord | None = None
        self._merged: dict[str, dict[str, Any]] = {}

    def state(self, record: FleetRecord | None) -> FleetRecord | None:
        """The fleet's state: ``record`` with each robot's progress laid over its entry (the
        robots' dict a copy of its own, their entries shared: a decision copies what it
        changes)."""
        if record is None:
            return None
        if record is not self._record:
            self._record = record
            self._merged = {
                k: {**robot, **self.robots.get(k, {})} for k, robot in record["robots"].items()
            }
        return {**record, "robots": dict(self._merged)}

    def learn(self, answer: list[bytes] | dict[bytes, bytes], at: int) -> None:
        """Take the progress hash as Redis answered it (HGETALL: a flat list from a script, a
        dict from the client) at Redis's time ``at`` (microseconds), unless a later one was
        taken already: answers of calls in flight at once may come back in any order, and a
        robot's own progress must never go back to an older copy."""
        if at < self._at:
            return
        self._at = at
        pairs = (
            answer
            if isinstance(answer, dict)
            else dict(zip(answer[::2], answer[1::2], strict=True))
        )
        raw = self._raw
        for robot, value in pairs.items():
            if raw.get(robot) != value:
                raw[robot] = value
                self._lay(robot.decode(), orjson.loads(value))
        if len(raw) != len(pairs):
            for robot in [r for r in raw if r not in pairs]:
                del raw[robot]
                self._lay(robot.decode(), None)

    def _lay(self, name: str, progress: dict[str, Any] | None) -> None:
        """A robot's progress, new (None: gone), laid over its entry in the record."""
        if progress is None:
            self.robots.pop(name, None)
        else:
            self.robots[name] = progress
        own = None if self._record is None else self._record["robots"].get(name)
        if own is not None:  # replaced, never changed in place: decisions share the entries
            self._merged[name] = {**own, **(progress or {})}

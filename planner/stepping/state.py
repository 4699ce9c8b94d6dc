"""What a stepping robot's session keeps (its :class:`SessionState`, plain data a store can keep
as JSON) and what one step answers (:class:`Step`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

__all__ = ["MOVES", "Pose", "SessionState", "Status", "Step"]

#: Move names by kernel move index; ``WAIT`` stays put.
MOVES = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")

Status = Literal["ready", "moving", "waiting", "replanned", "arrived", "blocked", "yielding"]

Pose = tuple[float, float, float]
"""``(x, y, yaw)``: meters in the map frame, radians."""


@dataclass(frozen=True, slots=True)
class Step:
    """The answer to one step: where the robot goes now and how the episode stands."""

    seq: int
    previous: tuple[int, int]
    position: tuple[int, int]
    move: str
    status: Status
    iteration: int
    path_length: float
    arc_cost: float
    remaining: float | None
    """Plain cost-to-go ``k`` from ``position`` (None when the goal cannot be reached); off the
    plan's sealed grid, the length of the narrow route the robot follows out."""
    narrow_fallback: bool = False
    """The robot follows a route through tight tunnels: the plan's own narrow fallback, or a
    detour that only the unsealed grid allows (a sealed pocket left, or the wide way parked)."""
    poses: tuple[Pose, ...] = ()
    """The path ahead (docs/api.md, "Stepping with poses"): from the robot's reported point (else
    from ``position``'s center), at least ``horizon_m`` or to the goal, clear of this step's
    dynamic obstacles; one pose when the robot waits. Empty when the session makes none."""
    remaining_m: float | None = None
    """Meters to the goal: along ``poses``, then along the detour they follow and the grid's
    ``k`` in meters from where it ends."""
    blocked_at: tuple[float, float] | None = None
    """A waiting robot's way cut with no way round: the point (meters, the center of the
    route's first blocked cell) where it is cut; else None."""

    def as_dict(self) -> dict[str, Any]:
        return {
            "seq": self.seq,
            "previous": list(self.previous),
            "position": list(self.position),
            "move": self.move,
            "status": self.status,
            "iteration": self.iteration,
            "path_length": self.path_length,
            "arc_cost": self.arc_cost,
            "remaining": self.remaining,
            "narrow_fallback": self.narrow_fallback,
            "poses": self.poses,
            "remaining_m": self.remaining_m,
            "blocked_at": self.blocked_at,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Step:
        (pr, pc), (r, c) = d["previous"], d["position"]
        poses: tuple[Pose, ...] = tuple(map(tuple, d.get("poses", ())))
        return cls(
            d["seq"], (pr, pc), (r, c), d["move"], d["status"], d["iteration"],
            d["path_length"], d["arc_cost"], d["remaining"], d.get("narrow_fallback", False),
            poses, d.get("remaining_m"), _point(d.get("blocked_at")),
        )  # fmt: skip


@dataclass(slots=True)
class SessionState:
    """Everything that changes as the robot steps; JSON-ready through :meth:`as_dict` (cells as
    tuples, which every JSON encoder writes as arrays: the trajectory grows with the episode,
    and a service writes the state back after every step)."""

    position: tuple[int, int]
    status: Status = "ready"
    iteration: int = 0
    path_length: float = 0.0
    arc_cost: float = 0.0
    held_up: int = 0
    replan_at: int = 0
    waits: int = 0
    replans: int = 0
    detour: list[int] = field(default_factory=list)
    narrow_fallback: bool = False
    """The current ``detour`` crosses cells that sealing closed."""
    trajectory: list[tuple[int, int]] = field(default_factory=list)
    last_seq: int | None = None
    last_step: Step | None = None
    leg: int = 0
    """Through waypoints: the leg the robot is on (it goes to ``waypoints[leg]``, the goal
    after the last)."""
    leg_start: int = 0
    """The ``trajectory``'s index where the current leg began: the paper decision's tabu list
    holds the cells visited since."""

    def as_dict(self) -> dict[str, Any]:
        return {
            "position": list(self.position),
            "status": self.status,
            "iteration": self.iteration,
            "path_length": self.path_length,
            "arc_cost": self.arc_cost,
            "held_up": self.held_up,
            "replan_at": self.replan_at,
            "waits": self.waits,
            "replans": self.replans,
            "detour": list(self.detour),
            "narrow_fallback": self.narrow_fallback,
            "trajectory": list(self.trajectory),
            "last_seq": self.last_seq,
            "last_step": None if self.last_step is None else self.last_step.as_dict(),
            "leg": self.leg,
            "leg_start": self.leg_start,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SessionState:
        last = d.get("last_step")
        r, c = d["position"]
        get = d.get  # a key left out (a record from an older version): the field's default
        return cls(  # the fields in order (a step reads its state back every time)
            (r, c), get("status", "ready"), get("iteration", 0), get("path_length", 0.0),
            get("arc_cost", 0.0), get("held_up", 0), get("replan_at", 0), get("waits", 0),
            get("replans", 0), list(get("detour", ())), get("narrow_fallback", False),
            [(r, c) for r, c in get("trajectory", ())], get("last_seq"),
            None if last is None else Step.from_dict(last), get("leg", 0), get("leg_start", 0),
        )  # fmt: skip

    def copy(self) -> SessionState:
        """A copy with lists of its own (a step changes them in place; a step is immutable)."""
        return SessionState(
            self.position, self.status, self.iteration, self.path_length, self.arc_cost,
            self.held_up, self.replan_at, self.waits, self.replans, list(self.detour),
            self.narrow_fallback, list(self.trajectory), self.last_seq, self.last_step, self.leg,
            self.leg_start,
        )  # fmt: skip


def _point(value: Any) -> tuple[float, float] | None:
    """A stored ``[x, y]`` (a JSON array, or an answer's ``{"x", "y"}``) as a tuple; None
    stays None."""
    if value is None:
        return None
    x, y = (value["x"], value["y"]) if isinstance(value, dict) else value
    return (float(x), float(y))

"""Planner parameters and the named presets (docs/algorithm.md, "Presets").

>>> resolve_params("mmas").seal_tunnels
False
>>> resolve_params("wide", alpha=4).alpha
4.0
>>> resolve_params("wide", gamma=1)
Traceback (most recent call last):
...
planner.errors.InvalidInput: unknown parameter 'gamma'; known: allow_narrow alpha beta clean_radius clean_weight decision deviation_m diagonal_cost dynamic_margin dynamic_margin_m footprint horizon_m max_acceleration max_angular_velocity max_detour max_velocity min_turning_radius motion nominal_speed occupied_threshold patience robot_radius seal_tunnels unknown wall_cost wide_distance wide_weight
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

from planner.errors import InvalidInput, quote
from planner.footprint import footprint_of

__all__ = [
    "PARAMETER_RANGES",
    "PRESETS",
    "Decision",
    "Motion",
    "Params",
    "Unknown",
    "WallCost",
    "resolve_params",
]

Decision = Literal["wide", "paper"]
Unknown = Literal["blocked", "free"]
WallCost = Literal["auto", "cells", "meters"]
Motion = Literal["diff", "car", "car_reverse"]

SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True, slots=True)
class Params:
    """Every knob of the planner. Build one with :func:`resolve_params`, which validates."""

    decision: Decision = "wide"
    """``wide`` (loop-free descent of ``kw``) or ``paper`` (Eq. 3 with a tabu list)."""
    seal_tunnels: bool = True
    """Seal tight-tunnel cells (one-cell corridors) before planning."""
    clean_weight: float = 0.5
    """The paper's clean weight: penalty per blocked neighbour."""
    clean_radius: int = 2
    """Blocked cells up to this Chebyshev distance d add ``clean_weight / d`` (1: the paper)."""
    diagonal_cost: float = SQRT2
    """Cost of a diagonal move (the paper: 1.4)."""
    alpha: float = 3.0
    """Pheromone weight of Eq. (3), ``paper`` decision."""
    beta: float = 1.0
    """Heuristic weight of Eq. (3), ``paper`` decision."""
    patience: int = 3
    """Held-up steps before the robot replans around the dynamic obstacles it sees."""
    allow_narrow: bool = True
    """When sealing cuts the start off the goal, plan through the tunnels instead of refusing."""
    robot_radius: float = 0.0
    """The robot's radius in meters: a cell is traversable when free and its center is more than
    this from the nearest blocked cell's center (the configuration space)."""
    unknown: Unknown = "blocked"
    """How unknown cells and the area outside the map count: ``blocked`` or ``free``."""
    occupied_threshold: int = 65
    """A cell is blocked when its occupancy (0..100) is at least this."""
    wall_cost: WallCost = "cells"
    """The wall term: ``cells`` (the paper's ``clean``, ``clean_weight`` per blocked cell within
    ``clean_radius``), ``meters`` (``wide_weight * (1 - s / wide_distance) ** 4`` for a clearance
    ``s`` beyond the robot's radius below ``wide_distance`` meters), or ``auto`` (``cells`` on a
    plain 0/1 grid in the default frame with a point robot, ``meters`` on any other map)."""
    wide_weight: float = 80.0
    """The metric wall term's weight, at the edge of the configuration space (per cell entered,
    where a move costs 1 a cell)."""
    wide_distance: float = 0.6
    """Meters of clearance beyond the robot's radius at which the metric wall term reaches 0."""
    dynamic_margin: int = 1
    """Cells (Chebyshev distance) around each dynamic obstacle treated as blocked for a step: 1
    covers every cell an obstacle can reach in one move, so a robot moving at the same time as
    the obstacles never meets one; 0 blocks only the cells they occupy (the paper's robot)."""
    dynamic_margin_m: float | None = None
    """The same margin in meters, for maps in meters: when set, a plan uses
    ``ceil(dynamic_margin_m / resolution)`` cells as its ``dynamic_margin`` (say 0.3 m for people
    walking about at a step of 0.2 s)."""
    horizon_m: float = 2.0
    """Meters of the path ahead that a step answers at least (its ``poses``), or to the goal."""
    deviation_m: float = 0.5
    """A fleet robot reported farther than this from its told moves is off its plan: the fleet
    is solved again from where it is."""
    nominal_speed: float = 0.5
    """The robot's speed in m/s outside speed zones: a plan's ``duration_s`` drives its poses at
    it, capped by each speed zone's ``max_speed``."""
    max_detour: float = 1.3
    """The ``wide`` route is at most this many times as long as the shortest route on the same
    configuration space: width is given up first (docs/algorithm.md, "Bounded detours")."""
    footprint: tuple[tuple[float, float], ...] | None = None
    """The robot's outline in its own frame (meters, x forward; 3 to 32 vertices) in place of
    ``robot_radius``, which becomes the footprint's inscribed radius (docs/shapes.md)."""
    motion: Motion = "diff"
    """``diff`` (turns in place), ``car`` (forward arcs) or ``car_reverse`` (forward and
    reverse)."""
    min_turning_radius: float | None = None
    """A car motion's least turning radius in meters (the car motions need one)."""
    max_velocity: float | None = None
    """m/s: when set, ``duration_s`` follows a trapezoid speed profile instead of
    ``nominal_speed`` (with ``max_acceleration`` m/s² and ``max_angular_velocity`` rad/s)."""
    max_acceleration: float | None = None
    """m/s² of the trapezoid profile (none: speeds change at once)."""
    max_angular_velocity: float | None = None
    """rad/s: a curve's speed is at most this over its curvature; turns in place take their
    angle over it (none: no limit)."""

    def as_dict(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in _NAMES}


#: Valid ranges (inclusive) of the numeric parameters.
PARAMETER_RANGES: dict[str, tuple[float, float]] = {
    "clean_weight": (0.0, 100.0),
    "clean_radius": (1, 8),
    "diagonal_cost": (1.0, 2.0),
    "alpha": (0.0, 20.0),
    "beta": (0.0, 20.0),
    "patience": (0, 1000),
    "robot_radius": (0.0, 100.0),
    "occupied_threshold": (1, 100),
    "wide_weight": (0.0, 1000.0),
    "wide_distance": (0.0, 100.0),
    "dynamic_margin": (0, 16),
    "dynamic_margin_m": (0.0, 5.0),
    "horizon_m": (0.0, 100.0),
    "nominal_speed": (0.0, 100.0),
    "deviation_m": (0.0, 100.0),
    "max_detour": (1.0, 100.0),
    "min_turning_radius": (0.0, 100.0),
    "max_velocity": (0.0, 100.0),
    "max_acceleration": (0.0, 1000.0),
    "max_angular_velocity": (0.0, 1000.0),
}

_PAPER = Params(
    decision="paper", clean_radius=1, diagonal_cost=1.4, alpha=3.0, beta=1.0, dynamic_margin=0
)

PRESETS: dict[str, Params] = {
    "wide": Params(wall_cost="auto"),
    "wfs-mmas": dataclasses.replace(_PAPER, seal_tunnels=True, clean_weight=0.5),
    "mmas": dataclasses.replace(_PAPER, seal_tunnels=False, clean_weight=0.0),
    "shortest": Params(decision="wide", seal_tunnels=False, clean_weight=0.0, clean_radius=1),
}

_FIELDS = {f.name: f for f in dataclasses.fields(Params)}
_CHOICES: dict[str, tuple[str, ...]] = {
    "unknown": ("blocked", "free"),
    "wall_cost": ("auto", "cells", "meters"),
    "motion": ("diff", "car", "car_reverse"),
}
_TOP_LEVEL = ("footprint", "motion", "min_turning_radius")
"""Parameters a plan request gives beside ``params``: their errors name them so."""
_POSITIVE = ("nominal_speed", "min_turning_radius", "max_velocity", "max_acceleration",
             "max_angular_velocity")  # fmt: skip
_NAMES = tuple(_FIELDS)


def resolve_params(preset: str = "wide", /, **overrides: Any) -> Params:
    """The preset's parameters with ``overrides`` applied one by one, each validated."""
    if preset not in PRESETS:
        msg = f"unknown preset {quote(preset)}; choose one of {', '.join(sorted(PRESETS))}"
        raise InvalidInput(msg, field="preset")
    values = PRESETS[preset].as_dict()
    for name, value in overrides.items():
        values[name] = _check(name, value)
    if "dynamic_margin" in overrides and overrides.get("dynamic_margin_m") is not None:
        msg = (
            "give dynamic_margin (cells) or dynamic_margin_m (meters), not both; got "
            f"dynamic_margin {quote(overrides['dynamic_margin'])} and dynamic_margin_m "
            f"{quote(overrides['dynamic_margin_m'])}"
        )
        raise InvalidInput(msg, field="params.dynamic_margin_m")
    if values["footprint"] is not None:
        inscribed = footprint_of(values["footprint"]).inscribed_radius
        given = overrides.get("robot_radius")
        if given not in (None, 0, 0.0) and abs(given - inscribed) > 1e-9:
            msg = (
                f"give a footprint or a robot_radius, not both: robot_radius {quote(given)} is "
                f"not the footprint's inscribed radius {inscribed:g}"
            )
            raise InvalidInput(msg, field="robot_radius")
        values["robot_radius"] = inscribed
    if values["motion"] != "diff" and values["min_turning_radius"] is None:
        msg = f"a {values['motion']} motion needs min_turning_radius (meters, > 0)"
        raise InvalidInput(msg, field="min_turning_radius")
    return Params(**values)


def _check(name: str, value: Any) -> Any:
    field = name if name in _TOP_LEVEL else f"params.{name}"
    if name == "rho":
        msg = (
            "rho is not a parameter: the pheromone trail is the goal wave's exact cost-to-go "
            "k, which evaporation does not change (Wave.tau(rho) gives the MMAS pheromone)"
        )
        raise InvalidInput(msg, field=field)
    if name not in _FIELDS:
        msg = f"unknown parameter {quote(name, 20)}; known: {' '.join(sorted(_FIELDS))}"
        raise InvalidInput(msg, field=field)
    if name == "decision":
        if value not in ("wide", "paper"):
            raise InvalidInput(
                f"decision must be 'wide' or 'paper'; got {quote(value)}", field=field
            )
        return value
    if name in _CHOICES:
        if value not in _CHOICES[name]:
            choices = " or ".join(repr(c) for c in _CHOICES[name])
            raise InvalidInput(f"{name} must be {choices}; got {quote(value)}", field=field)
        return value
    if name in ("dynamic_margin_m", *_TOP_LEVEL, *_POSITIVE[1:]) and value is None:
        return None
    if name == "footprint":
        return footprint_of(value, field).vertices
    if name in ("seal_tunnels", "allow_narrow"):
        if not isinstance(value, bool):
            raise InvalidInput(f"{name} must be true or false; got {quote(value)}", field=field)
        return value
    integral = name in ("clean_radius", "patience", "occupied_threshold", "dynamic_margin")
    ok_type = isinstance(value, int) if integral else isinstance(value, int | float)
    if isinstance(value, bool) or not ok_type:
        kind = "an integer" if integral else "a number"
        raise InvalidInput(f"{name} must be {kind}; got {quote(value)}", field=field)
    low, high = PARAMETER_RANGES[name]
    if name == "max_detour" and not (math.isfinite(value) and low <= value <= high):
        msg = (
            f"max_detour must be a finite number from {low:g} to {high:g} (how many times as "
            "long as the shortest route the wide route may be; 1: the shortest route); got "
            f"{quote(value)}"
        )
        raise InvalidInput(msg, field=field)
    if name in _POSITIVE and value <= 0:
        raise InvalidInput(f"{name} must be > 0; got {quote(value)}", field=field)
    if not (math.isfinite(value) and low <= value <= high):
        raise InvalidInput(f"{name} must be in [{low}, {high}]; got {quote(value)}", field=field)
    return int(value) if integral else float(value)

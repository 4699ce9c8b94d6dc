"""The paper's "robot environment analysis" (docs/algorithm.md): cell states, gates, tight
tunnels and the ``clean`` field of a grid or a configuration space, and its cache key."""

from __future__ import annotations

import time
from collections.abc import Hashable
from dataclasses import KW_ONLY, dataclass
from functools import cached_property
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.analysis.cells import BLOCKED_CELL, FREE, TUNNEL, classify, gate_cells
from planner.analysis.clean import clean_field
from planner.analysis.cspace import CSpace, configuration_space, wide_clean
from planner.analysis.distance import squared_distances
from planner.errors import InvalidInput, quote
from planner.maps.frames import MapFrame
from planner.maps.grids import as_grid
from planner.maps.robot_maps import RobotMap
from planner.maps.zones import Zones
from planner.params import PARAMETER_RANGES, Params, WallCost, resolve_params

__all__ = [
    "Analysis",
    "analyse",
    "analyse_map",
    "analysis_key",
    "analysis_params",
    "params_key",
    "resolve_wall_cost",
]


@dataclass(eq=False, repr=False)  # by identity: its fields are large arrays
class Analysis:
    """A map's analysis: cell states, gate and tunnel counts, the ``clean`` field.

    ``state`` holds 0 (free), 1 (obstacle) or 2 (tight-tunnel cell, sealed when
    ``seal_tunnels`` is on). ``clean`` is the penalty of every non-obstacle cell, counted with
    sealed cells and the outside of the map as blocked.

    An analysis of a robot map (:func:`analyse_map`) runs on its configuration space: an
    obstacle there is any cell the robot's center cannot occupy; ``cspace`` keeps the map's own
    blocked cells and distances, ``frame`` its meters. ``params_key`` is what the analysis was
    made with (see :func:`analysis_params`); ``zones`` the zoned map's zones (its speed zones
    cap the poses' speed).
    """

    state: npt.NDArray[np.uint8]
    clean: npt.NDArray[np.float32]
    _: KW_ONLY
    gates: int
    tunnels: int
    seal_tunnels: bool
    clean_weight: float
    clean_radius: int
    elapsed_ms: float
    frame: MapFrame
    params_key: tuple[Hashable, ...]
    cspace: CSpace | None = None
    wall_cost: WallCost = "cells"
    plain: bool = True
    zones: Zones | None = None

    def __post_init__(self) -> None:
        self.state.flags.writeable = False
        self.clean.flags.writeable = False

    @property
    def penalised(self) -> bool:
        """Whether entering a cell may pay a wall term (so ``kw`` differs from ``k``)."""
        if self.wall_cost == "meters":
            return bool(self.clean.any())
        return self.clean_weight > 0

    @cached_property
    def shape(self) -> tuple[int, int]:
        return (int(self.state.shape[0]), int(self.state.shape[1]))

    @property
    def grid(self) -> npt.NDArray[np.uint8]:
        """The static map: 1 where blocked."""
        grid: npt.NDArray[np.uint8] = (self.state == BLOCKED_CELL).astype(np.uint8)
        return grid

    @property
    def sealed(self) -> int:
        """How many tunnel cells are sealed (0 when ``seal_tunnels`` is off)."""
        return self.tunnels if self.seal_tunnels else 0

    def passable(self, *, narrow: bool = False) -> npt.NDArray[np.uint8]:
        """1 where the robot may stand: free cells, and tunnel cells unless they are sealed."""
        sealed = self.seal_tunnels and not narrow
        mask = self.state == FREE if sealed else self.state != BLOCKED_CELL
        out: npt.NDArray[np.uint8] = mask.astype(np.uint8)
        return out

    @cached_property
    def clearance(self) -> npt.NDArray[np.float32]:
        """Euclidean distance from each cell to the nearest static obstacle (the map's outside
        counts as one), in cells; 0 on obstacles. On a robot map: to the nearest blocked cell
        of the map itself (not of the configuration space), as the unknown policy says."""
        if self.cspace is not None:
            return self.cspace.distance
        free = np.ascontiguousarray(self.state != BLOCKED_CELL)
        squared = squared_distances(free, outside_blocked=True)
        out: npt.NDArray[np.float32] = np.sqrt(squared, out=squared).astype(np.float32)
        out.flags.writeable = False
        return out

    def gate_cells(self) -> npt.NDArray[np.int64]:
        """Every gate as a row ``[r1, c1, r2, c2]``: the two free cells of the diagonal gap."""
        return gate_cells(self.grid)

    @property
    def nbytes(self) -> int:
        cs = self.cspace
        if cs is not None:  # the clearance is the configuration space's distance
            extra = cs.blocked.nbytes + cs.distance.nbytes + cs.traversable.nbytes
            extra += cs.unknown_cells.nbytes
        else:
            extra = self.__dict__["clearance"].nbytes if "clearance" in self.__dict__ else 0
        return int(self.state.nbytes + self.clean.nbytes + extra)

    def summary(self) -> dict[str, Any]:
        return {
            "height": self.shape[0],
            "width": self.shape[1],
            "gates": self.gates,
            "tunnels": self.tunnels,
            "sealed": self.sealed,
            "analysis_ms": round(self.elapsed_ms, 3),
        }


def analyse(
    grid: Any, *, seal_tunnels: bool = True, clean_weight: float = 0.5, clean_radius: int = 2
) -> Analysis:
    """Analyse a 0/1 occupancy grid: gates, tight tunnels, the ``clean`` field.

    >>> grid = [[0, 0, 0, 0, 0],
    ...         [0, 0, 0, 0, 0],
    ...         [1, 1, 0, 1, 1],   # a one-cell gap: a tight tunnel
    ...         [0, 0, 0, 0, 0],
    ...         [0, 0, 0, 0, 0]]
    >>> a = analyse(grid, clean_radius=1)
    >>> a.tunnels, a.gates, a.passable()[2, 2]
    (1, 0, np.uint8(0))
    >>> float(a.clean[1, 2])   # three blocked neighbours below, the sealed cell among them
    1.5
    """
    g = as_grid(grid)
    low, high = PARAMETER_RANGES["clean_radius"]
    if not (isinstance(clean_radius, int) and low <= clean_radius <= high):
        msg = f"clean_radius must be an integer in [{low}, {high}]; got {quote(clean_radius)}"
        raise InvalidInput(msg, field="params.clean_radius")
    if not clean_weight >= 0:
        msg = f"clean_weight must be >= 0; got {quote(clean_weight)}"
        raise InvalidInput(msg, field="params.clean_weight")
    t0 = time.perf_counter()
    seal, weight, radius = bool(seal_tunnels), float(clean_weight), int(clean_radius)
    return _analysis(
        g, t0, seal, weight, radius, frame=MapFrame((g.shape[0], g.shape[1])),
        params_key=(0.0, "blocked", None, seal, "cells", weight, radius),
    )  # fmt: skip


def _analysis(
    grid: npt.NDArray[np.uint8],
    t0: float,
    seal_tunnels: bool,
    clean_weight: float,
    clean_radius: int,
    *,
    pad: int = 0,
    clean: npt.NDArray[np.float32] | None = None,
    **extra: Any,
) -> Analysis:
    """The analysis of a 0/1 ``grid`` begun at ``t0``: classified (on a copy padded with ``pad``
    free cells a side, then cropped, when the outside counts as free), its wall term ``clean``
    as given, else counted in cells (none when ``clean_weight`` is 0); ``extra`` goes to
    :class:`Analysis`."""
    H, W = grid.shape
    inner = (slice(pad, pad + H), slice(pad, pad + W))
    state, gates, tunnels = classify(np.pad(grid, pad) if pad else grid)
    if clean is None and clean_weight > 0:
        clean = clean_field(state, seal=seal_tunnels, weight=clean_weight, radius=clean_radius)
        clean = np.ascontiguousarray(clean[inner])
    if pad:
        state = np.ascontiguousarray(state[inner])
        tunnels = int(np.count_nonzero(state == TUNNEL))
    return Analysis(
        state,
        np.zeros((H, W), dtype=np.float32) if clean is None else clean,
        gates=gates,
        tunnels=tunnels,
        seal_tunnels=bool(seal_tunnels),
        clean_weight=clean_weight,
        clean_radius=int(clean_radius),
        elapsed_ms=(time.perf_counter() - t0) * 1e3,
        **extra,
    )


def resolve_wall_cost(params: Params, robot_map: RobotMap) -> WallCost:
    """``params.wall_cost`` with ``auto`` resolved: ``cells`` on a plain 0/1 grid in the default
    frame with a point robot and unknown space blocked (exactly the analysis of :func:`analyse`),
    ``meters`` on any other map."""
    return _wall(params, robot_map.plain)


def _wall(params: Params, plain: bool) -> WallCost:
    if params.wall_cost != "auto":
        return params.wall_cost
    legacy = plain and params.robot_radius == 0 and params.unknown == "blocked"
    return "cells" if legacy else "meters"


def analysis_params(params: Params, robot_map: RobotMap) -> tuple[Hashable, ...]:
    """The parameters an analysis of ``robot_map`` depends on, and only those: ``(robot_radius,
    unknown, occupied_threshold or None on a plain map, seal_tunnels, wall_cost resolved,
    clean_weight and clean_radius | wide_weight and wide_distance)``."""
    return params_key(params, plain=robot_map.plain)


def params_key(params: Params, *, plain: bool) -> tuple[Hashable, ...]:
    """:func:`analysis_params` for a map that is ``plain`` (see :attr:`RobotMap.plain`) or not."""
    wall = _wall(params, plain)
    threshold = None if plain else params.occupied_threshold
    weights: tuple[Hashable, ...] = (
        (params.clean_weight, params.clean_radius)
        if wall == "cells"
        else (params.wide_weight, params.wide_distance)
    )
    return (params.robot_radius, params.unknown, threshold, params.seal_tunnels, wall, *weights)


def analysis_key(robot_map: RobotMap, params: Params) -> tuple[Hashable, ...]:
    """The key to cache an analysis of ``robot_map`` for ``params`` by: the map's id and
    :func:`analysis_params`. Two requests with the same key may share one analysis.

    >>> from planner import grid_map
    >>> m = grid_map([[0, 1], [0, 0]])
    >>> analysis_key(m, resolve_params("wide"))[1:]
    (0.0, 'blocked', None, True, 'cells', 0.5, 2)
    >>> analysis_key(m, resolve_params("wide", robot_radius=0.5))[1:]
    (0.5, 'blocked', None, True, 'meters', 80.0, 0.6)
    """
    return (robot_map.map_id, *analysis_params(params, robot_map))


def analyse_map(robot_map: RobotMap, params: Params | None = None) -> Analysis:
    """Analyse a robot map for ``params`` (default: the ``wide`` preset) over the robot's
    configuration space: gates, tight tunnels (passages the robot only just fits through) and
    the wall term (``params.wall_cost``). On a plain 0/1 grid with a point robot this is exactly
    :func:`analyse` of the grid.

    >>> from planner import grid_map
    >>> m = grid_map([[0] * 7] * 3 + [[1, 1, 0, 0, 0, 1, 1]] + [[0] * 7] * 3, resolution=0.1)
    >>> a = analyse_map(m, resolve_params("wide", robot_radius=0.1, unknown="free"))
    >>> a.state[3].tolist()   # the robot only just fits through the 0.3 m gap: a tight tunnel
    [1, 1, 1, 2, 1, 1, 1]
    """
    p = params if params is not None else resolve_params()
    wall = resolve_wall_cost(p, robot_map)
    key = analysis_params(p, robot_map)
    t0 = time.perf_counter()
    cs = configuration_space(
        robot_map,
        robot_radius=p.robot_radius,
        unknown=p.unknown,
        occupied_threshold=p.occupied_threshold,
    )
    grid = np.ascontiguousarray(1 - cs.traversable, dtype=np.uint8)
    clean = None
    if wall == "meters":
        clean = wide_clean(cs, weight=p.wide_weight, wide_distance=p.wide_distance)
    # When the outside counts as free, the grid is classified padded with free cells (wide enough
    # that the padding's own edge is out of the clean radius).
    pad = p.clean_radius + 1 if p.unknown == "free" else 0
    return _analysis(
        grid, t0, p.seal_tunnels, float(p.clean_weight), p.clean_radius, pad=pad, clean=clean,
        frame=robot_map.frame, cspace=cs, wall_cost=wall, params_key=key, plain=robot_map.plain,
        zones=robot_map.zones,
    )  # fmt: skip

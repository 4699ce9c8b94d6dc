"""The paper's "robot environment analysis" stage and its goal wave (docs/algorithm.md).

Two layers, each cacheable on its own: :func:`analyse` (per map and analysis parameters) finds
gates and tight tunnels and computes the ``clean`` field; :func:`goal_wave` (per analysis, goal
and wave parameters) computes the cost-to-go fields ``k`` and ``kw``. :func:`analyse_map` does
the first on a robot map in meters, over the robot's configuration space; :func:`analysis_key`
is what a cache must key its analyses by.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Hashable, Mapping
from functools import cached_property
from typing import Any, NamedTuple

import edt
import numpy as np
import numpy.typing as npt

from planner._errors import InvalidInput, quote
from planner.analysis import _kernels as K
from planner.maps.cspace import CSpace, configuration_space, wide_clean
from planner.maps.grids import as_cell, as_grid
from planner.maps.robot_maps import MapFrame, RobotMap
from planner.params import PARAMETER_RANGES, SQRT2, Params, WallCost, resolve_params

__all__ = [
    "Analysis",
    "Wave",
    "WaveView",
    "analyse",
    "analyse_map",
    "analysis_key",
    "analysis_params",
    "goal_wave",
    "params_key",
    "resolve_wall_cost",
]

# From this many cells on, a goal wave computes ``k`` and ``kw`` in two threads at once.
_THREADED_CELLS = 1 << 16


class Analysis:
    """A map's analysis: cell states, gate and tunnel counts, the ``clean`` field.

    ``state`` holds 0 (free), 1 (obstacle) or 2 (tight-tunnel cell, sealed when
    ``seal_tunnels`` is on). ``clean`` is the penalty of every non-obstacle cell, counted with
    sealed cells and the outside of the map as blocked.

    An analysis of a robot map (:func:`analyse_map`) runs on its configuration space: an
    obstacle there is any cell the robot's center cannot occupy; ``cspace`` keeps the map's own
    blocked cells and distances, ``frame`` its meters. ``params_key`` is what the analysis was
    made with (see :func:`analysis_params`).
    """

    def __init__(
        self,
        state: npt.NDArray[np.uint8],
        clean: npt.NDArray[np.float32],
        *,
        gates: int,
        tunnels: int,
        seal_tunnels: bool,
        clean_weight: float,
        clean_radius: int,
        elapsed_ms: float,
        frame: MapFrame | None = None,
        cspace: CSpace | None = None,
        wall_cost: WallCost = "cells",
        params_key: tuple[Hashable, ...] | None = None,
        plain: bool = True,
    ) -> None:
        self.state = state
        self.clean = clean
        self.gates = gates
        self.tunnels = tunnels
        self.seal_tunnels = seal_tunnels
        self.clean_weight = clean_weight
        self.clean_radius = clean_radius
        self.elapsed_ms = elapsed_ms
        self.frame = frame if frame is not None else MapFrame((state.shape[0], state.shape[1]))
        self.cspace = cspace
        self.wall_cost = wall_cost
        self.plain = plain
        self.params_key = (
            params_key
            if params_key is not None
            else (0.0, "blocked", None, seal_tunnels, "cells", clean_weight, clean_radius)
        )
        state.flags.writeable = False
        clean.flags.writeable = False

    @property
    def penalised(self) -> bool:
        """Whether entering a cell may pay a wall term (so ``kw`` differs from ``k``)."""
        if self.wall_cost == "meters":
            return bool(self.clean.any())
        return self.clean_weight > 0

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.state.shape[0]), int(self.state.shape[1]))

    @property
    def grid(self) -> npt.NDArray[np.uint8]:
        """The static map: 1 where blocked."""
        grid: npt.NDArray[np.uint8] = (self.state == K.BLOCKED_CELL).astype(np.uint8)
        return grid

    @property
    def sealed(self) -> int:
        """How many tunnel cells are sealed (0 when ``seal_tunnels`` is off)."""
        return self.tunnels if self.seal_tunnels else 0

    def passable(self, *, narrow: bool = False) -> npt.NDArray[np.uint8]:
        """1 where the robot may stand: free cells, and tunnel cells unless they are sealed."""
        sealed = self.seal_tunnels and not narrow
        mask = self.state == K.FREE if sealed else self.state != K.BLOCKED_CELL
        out: npt.NDArray[np.uint8] = mask.astype(np.uint8)
        return out

    @cached_property
    def clearance(self) -> npt.NDArray[np.float32]:
        """Euclidean distance from each cell to the nearest static obstacle (the map's outside
        counts as one), in cells; 0 on obstacles. On a robot map: to the nearest blocked cell
        of the map itself (not of the configuration space), as the unknown policy says."""
        if self.cspace is not None:
            return self.cspace.distance
        free = np.ascontiguousarray(self.state != K.BLOCKED_CELL)
        out: npt.NDArray[np.float32] = edt.edt(free, black_border=True).astype(
            np.float32, copy=False
        )
        out.flags.writeable = False
        return out

    def gate_cells(self) -> npt.NDArray[np.int64]:
        """Every gate as a row ``[r1, c1, r2, c2]``: the two free cells of the diagonal gap."""
        result: npt.NDArray[np.int64] = K._gate_cells(self.grid)
        return result

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
    state, gates, tunnels = K._classify_rows(g)
    if clean_weight > 0:
        clean = K._clean_rows(state, bool(seal_tunnels), float(clean_weight), int(clean_radius))
    else:
        clean = np.zeros(g.shape, dtype=np.float32)
    elapsed = (time.perf_counter() - t0) * 1e3
    return Analysis(
        state,
        clean,
        gates=int(gates),
        tunnels=int(tunnels),
        seal_tunnels=bool(seal_tunnels),
        clean_weight=float(clean_weight),
        clean_radius=int(clean_radius),
        elapsed_ms=elapsed,
    )


class WaveView(NamedTuple):
    """The part of a wave a decision at a cell reads, as arrays that the decision kernels take:
    the wave's grid, ``k``, ``kw`` and ``clean`` over a window whose top-left cell is
    (``top``, ``left``) of the map (the whole map for a whole-map wave; the 3 x 3 cells around
    the robot, settled, for a resumable one)."""

    passable: npt.NDArray[np.uint8]
    k: npt.NDArray[np.float64]
    kw: npt.NDArray[np.float64]
    clean: npt.NDArray[np.float32]
    top: int
    left: int


class Wave:
    """The goal wave: cost-to-go fields over the whole map.

    ``k`` is the plain cost-to-go (the paper's pheromone trail, summed as "total arc cost");
    ``kw`` the wide one, where entering a cell Y also pays ``clean(Y)``. Unreachable: +inf.
    ``passable`` is the grid the wave ran over (sealed or, with ``narrow``, unsealed; the goal
    is always passable).
    """

    def __init__(
        self,
        goal: tuple[int, int],
        k: npt.NDArray[np.float64],
        kw: npt.NDArray[np.float64],
        passable: npt.NDArray[np.uint8],
        *,
        narrow: bool,
        diagonal_cost: float,
        elapsed_ms: float,
    ) -> None:
        self.goal = goal
        self._k = k
        self._kw = kw
        self._passable = passable
        self.narrow = narrow
        self.diagonal_cost = diagonal_cost
        self.elapsed_ms = elapsed_ms
        self._view: WaveView | None = None
        for arr in (k, kw, passable):
            arr.flags.writeable = False

    @property
    def k(self) -> npt.NDArray[np.float64]:
        """The plain cost-to-go of every cell."""
        return self._k

    @property
    def kw(self) -> npt.NDArray[np.float64]:
        """The wide cost-to-go of every cell."""
        return self._kw

    @property
    def passable(self) -> npt.NDArray[np.uint8]:
        """1 on the cells of the grid the wave ran over."""
        return self._passable

    def view(self, r: int, c: int, clean: npt.NDArray[np.float32]) -> WaveView:
        """What a decision at (r, c) reads (see :class:`WaveView`): here, the whole fields
        (one view, kept: a stepping robot asks for it several times a step)."""
        view = self._view
        if view is None or view.clean is not clean:
            view = self._view = WaveView(self.passable, self.k, self.kw, clean, 0, 0)
        return view

    def detour(
        self,
        start: int,
        obstacles: npt.NDArray[np.int64],
        clean: npt.NDArray[np.float32],
        margin: int = 0,
    ) -> npt.NDArray[np.int64]:
        """The replan of docs/algorithm.md from ``start`` (a flat index) over the wave's grid with
        every cell within Chebyshev ``margin`` of a dynamic obstacle blocked: the cells after
        ``start`` up to the goal, empty when cut off."""
        W = self.shape[1]
        out: npt.NDArray[np.int64] = K._detour(
            self.passable, self.kw, clean, start, self.goal[0] * W + self.goal[1],
            self.diagonal_cost, obstacles, margin, True,
        )  # fmt: skip
        return out

    def on_grid(self, cells: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
        """Whether each cell (flat indices) is on the grid the wave ran over."""
        out: npt.NDArray[np.bool_] = self.passable.ravel()[cells] == 1
        return out

    def k_at(self, r: int, c: int) -> float:
        """``k`` at (r, c)."""
        return float(self.k[r, c])

    def k_along(self, path: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """``k`` of each cell of ``path`` (``(n, 2)`` cells)."""
        out: npt.NDArray[np.float64] = self.k[path[:, 0], path[:, 1]]
        return out

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self._passable.shape[0]), int(self._passable.shape[1]))

    def tau(
        self, rho: float = 0.98, *, tau_min: float = 0.01, tau_max: float = 1.0
    ) -> npt.NDArray[np.float64]:
        """The MMAS pheromone of every cell, ``clamp(tau_max * rho ** k, tau_min, tau_max)``."""
        with np.errstate(over="ignore", under="ignore"):
            out: npt.NDArray[np.float64] = np.clip(tau_max * rho**self.k, tau_min, tau_max)
        return out

    @property
    def nbytes(self) -> int:
        shared = self._kw is self._k
        return int(self.k.nbytes + (0 if shared else self.kw.nbytes) + self.passable.nbytes)


def goal_wave(
    analysis: Analysis, goal: Any, *, diagonal_cost: float = SQRT2, narrow: bool = False
) -> Wave:
    """Run the goal wave over ``analysis``'s sealed grid (or, with ``narrow``, the unsealed one).
    ``goal`` is a ``[row, col]`` cell or a point ``{"x", "y"}`` in meters.

    >>> w = goal_wave(analyse([[0, 0], [0, 0]], seal_tunnels=False, clean_weight=0), [0, 0])
    >>> w.k.round(3).tolist()
    [[0.0, 1.0], [1.0, 1.414]]
    """
    if isinstance(goal, Mapping):  # a point in meters: the cell holding it
        r, c = analysis.frame.cell_of(goal, name="goal")
    else:
        r, c = as_cell(goal, analysis.shape, name="goal")
    if analysis.state[r, c] == K.BLOCKED_CELL:
        raise InvalidInput(f"goal [{r}, {c}] is on an obstacle", field="goal")
    low, high = PARAMETER_RANGES["diagonal_cost"]
    if not low <= diagonal_cost <= high:
        msg = f"diagonal_cost must be in [{low}, {high}]; got {quote(diagonal_cost)}"
        raise InvalidInput(msg, field="params.diagonal_cost")
    t0 = time.perf_counter()
    passable = analysis.passable(narrow=narrow)
    passable[r, c] = 1
    flat_goal = r * analysis.shape[1] + c
    masks = K._move_masks_rows(passable)
    args = (masks, flat_goal, float(diagonal_cost), analysis.clean)
    if not analysis.penalised:
        k = kw = K._wave(*args, False)
    elif passable.size < _THREADED_CELLS:
        k = K._wave(*args, False)
        kw = K._wave(*args, True)
    else:
        # The kernels release the GIL: the two fields run side by side, sharing the masks.
        fields: dict[bool, npt.NDArray[np.float64]] = {}
        worker = threading.Thread(target=lambda: fields.update({False: K._wave(*args, False)}))
        worker.start()
        kw = K._wave(*args, True)
        worker.join()
        k = fields[False]
    elapsed = (time.perf_counter() - t0) * 1e3
    return Wave(
        (r, c),
        k,
        kw,
        passable,
        narrow=narrow,
        diagonal_cost=float(diagonal_cost),
        elapsed_ms=elapsed,
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

    >>> from planner.maps.robot_maps import grid_map
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

    >>> from planner.maps.robot_maps import grid_map
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
    wants_cells = wall == "cells" and p.clean_weight > 0
    if p.unknown == "free":
        # The outside counts as free: classify and count on a grid padded with free cells (wide
        # enough that the padding's own edge is out of the clean radius), then crop.
        pad = p.clean_radius + 1
        padded = np.pad(grid, pad)
        state_p, gates, _ = K._classify(padded)
        inner = (slice(pad, pad + grid.shape[0]), slice(pad, pad + grid.shape[1]))
        state = np.ascontiguousarray(state_p[inner])
        tunnels = int(np.count_nonzero(state == K.TUNNEL))
        if wants_cells:
            clean_p = K._clean(state_p, bool(p.seal_tunnels), float(p.clean_weight), p.clean_radius)
            clean = np.ascontiguousarray(clean_p[inner])
    else:
        state, gates, tunnels = K._classify(grid)
        if wants_cells:
            clean = K._clean(state, bool(p.seal_tunnels), float(p.clean_weight), p.clean_radius)
    if wall == "meters":
        clean = wide_clean(cs, weight=p.wide_weight, wide_distance=p.wide_distance)
    elif not wants_cells:
        clean = np.zeros(grid.shape, dtype=np.float32)
    elapsed = (time.perf_counter() - t0) * 1e3
    return Analysis(
        state,
        clean,
        gates=int(gates),
        tunnels=int(tunnels),
        seal_tunnels=bool(p.seal_tunnels),
        clean_weight=float(p.clean_weight),
        clean_radius=int(p.clean_radius),
        elapsed_ms=elapsed,
        frame=robot_map.frame,
        cspace=cs,
        wall_cost=wall,
        params_key=key,
        plain=robot_map.plain,
    )

"""The paper's "robot environment analysis" stage and its goal wave (ALGORITHM.md §1-2).

Two layers, each cacheable on its own: :func:`analyse` (per map and analysis parameters) finds
gates and tight tunnels and computes the ``clean`` field; :func:`goal_wave` (per analysis, goal
and wave parameters) computes the cost-to-go fields ``k`` and ``kw``.
"""

from __future__ import annotations

import threading
import time
from functools import cached_property
from typing import Any, NamedTuple

import edt
import numpy as np
import numpy.typing as npt

from planner import _kernels as K
from planner._errors import InvalidInput, quote
from planner.grids import as_cell, as_grid
from planner.params import PARAMETER_RANGES, SQRT2

__all__ = ["Analysis", "Wave", "WaveView", "analyse", "goal_wave"]

# From this many cells on, a goal wave computes ``k`` and ``kw`` in two threads at once.
_THREADED_CELLS = 1 << 16


class Analysis:
    """A map's analysis: cell states, gate and tunnel counts, the ``clean`` field.

    ``state`` holds 0 (free), 1 (obstacle) or 2 (tight-tunnel cell, sealed when
    ``seal_tunnels`` is on). ``clean`` is the penalty of every non-obstacle cell, counted with
    sealed cells and the outside of the map as blocked.
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
    ) -> None:
        self.state = state
        self.clean = clean
        self.gates = gates
        self.tunnels = tunnels
        self.seal_tunnels = seal_tunnels
        self.clean_weight = clean_weight
        self.clean_radius = clean_radius
        self.elapsed_ms = elapsed_ms
        state.flags.writeable = False
        clean.flags.writeable = False

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.state.shape[0]), int(self.state.shape[1]))

    @property
    def grid(self) -> npt.NDArray[np.uint8]:
        """The static map: 1 where blocked."""
        grid: npt.NDArray[np.uint8] = (self.state == K.OBSTACLE).astype(np.uint8)
        return grid

    @property
    def sealed(self) -> int:
        """How many tunnel cells are sealed (0 when ``seal_tunnels`` is off)."""
        return self.tunnels if self.seal_tunnels else 0

    def passable(self, *, narrow: bool = False) -> npt.NDArray[np.uint8]:
        """1 where the robot may stand: free cells, and tunnel cells unless they are sealed."""
        sealed = self.seal_tunnels and not narrow
        mask = self.state == K.FREE if sealed else self.state != K.OBSTACLE
        out: npt.NDArray[np.uint8] = mask.astype(np.uint8)
        return out

    @cached_property
    def clearance(self) -> npt.NDArray[np.float32]:
        """Euclidean distance from each cell to the nearest static obstacle (the map's outside
        counts as one), in cells; 0 on obstacles."""
        free = np.ascontiguousarray(self.state != K.OBSTACLE)
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
        """What a decision at (r, c) reads (see :class:`WaveView`): here, the whole fields."""
        return WaveView(self.passable, self.k, self.kw, clean, 0, 0)

    def detour(
        self, start: int, obstacles: npt.NDArray[np.int64], clean: npt.NDArray[np.float32]
    ) -> npt.NDArray[np.int64]:
        """The replan of ALGORITHM.md §4 from ``start`` (a flat index) with the dynamic
        ``obstacles`` blocked: the cells after ``start`` up to the goal, empty when cut off."""
        W = self.shape[1]
        out: npt.NDArray[np.int64] = K._detour(
            self.passable, self.kw, clean, start, self.goal[0] * W + self.goal[1],
            self.diagonal_cost, obstacles,
        )  # fmt: skip
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

    >>> w = goal_wave(analyse([[0, 0], [0, 0]], seal_tunnels=False, clean_weight=0), [0, 0])
    >>> w.k.round(3).tolist()
    [[0.0, 1.0], [1.0, 1.414]]
    """
    r, c = as_cell(goal, analysis.shape, name="goal")
    if analysis.state[r, c] == K.OBSTACLE:
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
    if analysis.clean_weight == 0:
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

"""The paper's simulated experiment (ALGORITHM.md §5): one episode among random dynamic obstacles.

Each obstacle starts on a random free cell (not the start, not the goal) and every step first
moves to a random legal neighbouring cell or stays (never onto another obstacle or the robot);
then the robot is told where they are and takes its step. Everything is drawn from one seeded
generator, so an episode is reproducible.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner import _kernels as K
from planner._errors import InvalidInput, quote
from planner.planning import Plan, clearance_metrics, plan
from planner.session import Session

__all__ = ["Episode", "run_episode", "simulate", "warm_up"]

MAX_DYNAMIC = 10_000


@dataclass(frozen=True, eq=False, slots=True)
class Episode:
    """A finished episode: the robot's cells, the obstacles' cells at every step, the metrics."""

    plan: Plan
    trajectory: npt.NDArray[np.int64]
    """``(n, 2)`` cells the robot stood on, start first (a wait repeats no cell)."""
    obstacles: npt.NDArray[np.int64]
    """``(steps + 1, m, 2)``: the obstacles' cells at the start and after each of their moves
    (``(0, m, 2)`` when the episode was run without ``record``)."""
    metrics: dict[str, Any]


def simulate(
    grid: Any,
    start: Any,
    goal: Any,
    *,
    preset: str = "wide",
    dynamic: int = 10,
    seed: int = 0,
    max_steps: int | None = None,
    **params: Any,
) -> Episode:
    """Plan, then run one seeded episode among ``dynamic`` randomly moving obstacles.

    >>> e = simulate([[0] * 8 for _ in range(8)], [0, 0], [7, 7], dynamic=3, seed=1)
    >>> e.metrics["reached"], e.metrics["collisions"]
    (True, 0)
    """
    return run_episode(
        plan(grid, start, goal, preset=preset, **params),
        dynamic=dynamic,
        seed=seed,
        max_steps=max_steps,
    )


def run_episode(
    plan: Plan,
    *,
    dynamic: int = 10,
    seed: int = 0,
    max_steps: int | None = None,
    record: bool = True,
) -> Episode:
    """Run one seeded episode of ``plan`` among ``dynamic`` randomly moving obstacles.

    ``max_steps`` (default ``4 * (H + W) + 4 * len(path)``) bounds the episode. With ``record``
    off, the obstacles' cells at each step are not kept (``Episode.obstacles`` is empty).
    """
    grid = plan.analysis.grid
    H, W = grid.shape
    if isinstance(dynamic, bool) or not isinstance(dynamic, int) or not 0 <= dynamic <= MAX_DYNAMIC:
        msg = f"dynamic must be an integer in [0, {MAX_DYNAMIC}]; got {quote(dynamic)}"
        raise InvalidInput(msg, field="dynamic_count")
    if max_steps is None:
        max_steps = 4 * (H + W) + 4 * len(plan.path)
    if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
        raise InvalidInput(
            f"max_steps must be a positive integer; got {quote(max_steps)}", field="max_steps"
        )
    t_start = time.perf_counter()
    rng = np.random.default_rng(seed)
    free = np.flatnonzero(grid.ravel() == 0)
    free = free[
        (free != plan.start[0] * W + plan.start[1]) & (free != plan.goal[0] * W + plan.goal[1])
    ]
    if dynamic > free.size:
        msg = f"dynamic_count {dynamic} exceeds the {free.size} free cells besides start and goal"
        raise InvalidInput(msg, field="dynamic_count")
    cells = rng.choice(free, size=dynamic, replace=False)
    obstacles = np.ascontiguousarray(np.stack(np.divmod(cells, W), axis=1).astype(np.int64))
    occupied = np.zeros((H, W), dtype=np.int32)
    occupied[obstacles[:, 0], obstacles[:, 1]] = 1
    history = [obstacles.copy()] if record else []
    session = Session(plan)
    collisions = 0
    step_seconds = 0.0
    steps = 0
    while steps < max_steps and session.state.status not in ("arrived", "blocked"):
        r, c = session.state.position
        K._move_obstacles(grid, occupied, obstacles, r, c, rng.random(dynamic))
        if record:
            history.append(obstacles.copy())
        t0 = time.perf_counter()
        step = session.step(obstacles)
        step_seconds += time.perf_counter() - t0
        steps += 1
        pr, pc = step.position
        if occupied[pr, pc]:
            collisions += 1
    st = session.state
    trajectory = np.asarray(st.trajectory, dtype=np.int64).reshape(-1, 2)
    min_c, mean_c, contact = clearance_metrics(trajectory, plan.analysis)
    metrics: dict[str, Any] = {
        "reached": st.status == "arrived",
        "status": st.status,
        "iterations": st.iteration,
        "moves": len(trajectory) - 1,
        "waits": st.waits,
        "replans": st.replans,
        "path_length": round(st.path_length, 6),
        "arc_cost": round(st.arc_cost, 6),
        "gates": plan.gates,
        "tunnels": plan.tunnels,
        "narrow_fallback": plan.narrow_fallback,
        "min_clearance": round(min_c, 4),
        "mean_clearance": round(mean_c, 4),
        "contact_ratio": round(contact, 4),
        "collisions": collisions,
        "analysis_ms": round(plan.analysis.elapsed_ms + plan.wave.elapsed_ms, 3),
        "step_us": round(step_seconds / max(steps, 1) * 1e6, 3),
        "episode_ms": round((time.perf_counter() - t_start) * 1e3, 3),
    }
    shape = (len(history), dynamic, 2)
    obstacle_cells = np.stack(history) if history else np.empty(shape, dtype=np.int64)
    return Episode(plan, trajectory, obstacle_cells, metrics)


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel, so no later call pays for it.

    Numba compiles a kernel apart for read-only arrays (a service keeps its maps read-only), so
    both kinds of grid are warmed.
    """
    for writeable in (True, False):
        grid = np.zeros((6, 6), dtype=np.uint8)
        grid[2, 1:5] = 1
        grid[4, 3] = 1
        grid.flags.writeable = writeable
        for preset in ("wide", "wfs-mmas", "mmas"):
            p = plan(grid, (0, 0), (5, 5), preset=preset, patience=0)
            _ = plan(grid, (0, 0), (5, 5), preset=preset, whole=True).path  # a service's plans
            p.analysis.gate_cells()
            _ = p.min_clearance
            run_episode(p, dynamic=2, seed=0, max_steps=4)
            session = Session(p)
            session.step([[0, 1], [1, 0], [1, 1]])  # held up: exercises the replan kernel

"""The paper's simulated experiment (docs/algorithm.md, the experiment, docs/experiment.md): one
seeded, reproducible episode of a
robot among randomly moving dynamic obstacles, and its metrics."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from numba import njit

from planner.analysis.passages import find_passages
from planner.errors import InvalidInput, quote
from planner.fleets import attach, build_roadmap, solve
from planner.maps.robot_maps import grid_map
from planner.plans.moves import DC, DR
from planner.plans.planning import Plan, clearance_metrics, plan
from planner.stepping.session import Session

__all__ = ["Episode", "ObstacleMotion", "move_obstacles", "run_episode", "simulate", "warm_up"]

MAX_DYNAMIC = 10_000
STOP_EVERY = 256
"""Steps of an episode between two questions to its ``stop`` callable (about a millisecond)."""

ObstacleMotion = Literal["turns", "simultaneous"]
OBSTACLE_MOTIONS: tuple[ObstacleMotion, ...] = ("turns", "simultaneous")


@dataclass(frozen=True, eq=False, slots=True)
class Episode:
    """A finished episode: the robot's cells, the obstacles' cells at every step, the metrics."""

    plan: Plan
    trajectory: npt.NDArray[np.int64]
    """``(n, 2)`` cells the robot stood on, start first (a wait repeats no cell)."""
    dynamic_obstacles: npt.NDArray[np.int64]
    """``(steps + 1, m, 2)``: the dynamic obstacles' cells at the start and after each of their
    moves (``(0, m, 2)`` when the episode was run without ``record``)."""
    metrics: dict[str, Any]
    obstacle_motion: ObstacleMotion = "turns"
    """Whether the obstacles moved before the robot decided (``turns``) or with it."""


def simulate(
    grid: Any,
    start: Any,
    goal: Any,
    *,
    preset: str = "wide",
    dynamic_count: int = 10,
    seed: int = 0,
    max_steps: int | None = None,
    obstacle_motion: ObstacleMotion = "turns",
    **params: Any,
) -> Episode:
    """Plan, then run one seeded episode among ``dynamic_count`` randomly moving obstacles.

    >>> e = simulate([[0] * 8 for _ in range(8)], [0, 0], [7, 7], dynamic_count=3, seed=1)
    >>> e.metrics["reached"], e.metrics["collisions"]
    (True, 0)
    """
    return run_episode(
        plan(grid, start, goal, preset=preset, **params),
        dynamic_count=dynamic_count,
        seed=seed,
        max_steps=max_steps,
        obstacle_motion=obstacle_motion,
    )


def run_episode(
    plan: Plan,
    *,
    dynamic_count: int = 10,
    seed: int = 0,
    max_steps: int | None = None,
    record: bool = True,
    obstacle_motion: ObstacleMotion = "turns",
    stop: Callable[[], bool] | None = None,
) -> Episode:
    """Run one seeded episode of ``plan`` among ``dynamic_count`` randomly moving obstacles.

    Each obstacle starts on a random free cell (not the start, not the goal) and every tick
    moves to a random legal neighbouring cell or stays (never onto another obstacle or the
    robot's cell). Two orders of play (``obstacle_motion``): ``turns`` (the paper's), the
    obstacles move, then the robot is told where they are and steps; ``simultaneous`` (the real
    world), the robot decides from where the obstacles are at the tick's start, then they all
    move at once. A collision is the robot ending a tick on an obstacle's cell, or swapping
    cells with one. Everything is drawn from one seeded generator.

    ``max_steps`` (default ``4 * (H + W) + 4 * len(path)``) bounds the episode. With ``record``
    off, the obstacles' cells at each step are not kept (``Episode.dynamic_obstacles`` is empty).
    ``obstacle_motion`` is ``turns`` (obstacles move, then the robot) or ``simultaneous``.
    ``stop``, when given, is asked every ``STOP_EVERY`` steps whether to end the episode where
    it is (a caller's deadline or cancel flag: no thread can be stopped from outside).
    """
    grid = plan.analysis.grid
    H, W = grid.shape
    count = dynamic_count
    if isinstance(count, bool) or not isinstance(count, int) or not 0 <= count <= MAX_DYNAMIC:
        msg = f"dynamic_count must be an integer in [0, {MAX_DYNAMIC}]; got {quote(count)}"
        raise InvalidInput(msg, field="dynamic_count")
    if obstacle_motion not in OBSTACLE_MOTIONS:
        msg = f"obstacle_motion must be 'turns' or 'simultaneous'; got {obstacle_motion!r}"
        raise InvalidInput(msg, field="obstacle_motion")
    simultaneous = obstacle_motion == "simultaneous"
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
    if dynamic_count > free.size:
        msg = (
            f"dynamic_count {dynamic_count} exceeds the {free.size} free cells besides start "
            "and goal"
        )
        raise InvalidInput(msg, field="dynamic_count")
    cells = rng.choice(free, size=dynamic_count, replace=False)
    dynamic_obstacles = np.ascontiguousarray(np.stack(np.divmod(cells, W), axis=1).astype(np.int64))
    occupied = np.zeros((H, W), dtype=np.int32)
    occupied[dynamic_obstacles[:, 0], dynamic_obstacles[:, 1]] = 1
    history = [dynamic_obstacles.copy()] if record else []
    session = Session(plan, poses=False)
    collisions = 0
    step_seconds = 0.0
    steps = 0
    while steps < max_steps and session.state.status not in ("arrived", "blocked"):
        if stop is not None and steps % STOP_EVERY == 0 and steps and stop():
            break
        r, c = session.state.position
        before = dynamic_obstacles.copy()
        if not simultaneous:
            move_obstacles(grid, occupied, dynamic_obstacles, (r, c), rng.random(dynamic_count))
        t0 = time.perf_counter()
        step = session.step(dynamic_obstacles)
        step_seconds += time.perf_counter() - t0
        if simultaneous:
            # They move at once with the robot: away from the cell it stood on at the start.
            move_obstacles(grid, occupied, dynamic_obstacles, (r, c), rng.random(dynamic_count))
        if record:
            history.append(dynamic_obstacles.copy())
        steps += 1
        pr, pc = step.position
        landed = occupied[pr, pc] > 0
        swapped = bool(
            np.any(
                (before[:, 0] == pr) & (before[:, 1] == pc)
                & (dynamic_obstacles[:, 0] == r) & (dynamic_obstacles[:, 1] == c)
            )
        )  # fmt: skip
        if landed or swapped:
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
    shape = (len(history), dynamic_count, 2)
    obstacle_cells = np.stack(history) if history else np.empty(shape, dtype=np.int64)
    return Episode(plan, trajectory, obstacle_cells, metrics, obstacle_motion)


@njit(cache=True, nogil=True)
def _move_obstacles(
    grid: np.ndarray,
    occupied: np.ndarray,
    obstacles: np.ndarray,
    robot_r: int,
    robot_c: int,
    u: np.ndarray,
) -> None:
    """Move each obstacle in place to a uniformly drawn option among staying and its legal moves
    (free static cell, no corner cutting, not another obstacle's cell, not the robot's cell).

    ``occupied`` counts obstacles per cell and is kept up to date; ``u`` holds one uniform
    [0, 1) number per obstacle, drawn by the caller's seeded generator.
    """
    H, W = grid.shape
    m = obstacles.shape[0]
    options = np.empty(9, dtype=np.int64)
    for j in range(m):
        r = obstacles[j, 0]
        c = obstacles[j, 1]
        count = 1
        options[0] = -1
        for i in range(8):
            yr = r + DR[i]
            yc = c + DC[i]
            if yr < 0 or yr >= H or yc < 0 or yc >= W or grid[yr, yc] != 0:
                continue
            if i & 1 and (grid[r, yc] != 0 or grid[yr, c] != 0):
                continue
            if (yr == robot_r and yc == robot_c) or occupied[yr, yc]:
                continue
            options[count] = i
            count += 1
        pick = options[min(int(u[j] * count), count - 1)]
        if pick >= 0:
            occupied[r, c] -= 1
            obstacles[j, 0] = r + DR[pick]
            obstacles[j, 1] = c + DC[pick]
            occupied[r + DR[pick], c + DC[pick]] += 1


def move_obstacles(
    grid: npt.NDArray[np.uint8],
    occupied: npt.NDArray[np.int32],
    obstacles: npt.NDArray[np.int64],
    robot: tuple[int, int],
    u: npt.NDArray[np.float64],
) -> None:
    """One tick of the paper's random obstacles, in place (see ``_move_obstacles``)."""
    if occupied.shape != grid.shape or obstacles.shape != (u.shape[0], 2):
        shapes = (grid.shape, occupied.shape, obstacles.shape, u.shape)
        raise TypeError(
            f"grid and occupied must match, obstacles be (len(u), 2); {shapes!r} given."
        )
    _move_obstacles(grid, occupied, obstacles, robot[0], robot[1], u)


def warm_up(served: Callable[[], None] | None = None) -> None:
    """Compile (or load from numba's cache) every kernel, so no later call pays for it.

    A service's kernels first (the plans and steps of robot maps, whose arrays are read-only:
    numba compiles apart for those), then ``served()`` if given (a service may answer from
    then on), then the rest: plain grids of both kinds, the paper's presets, episodes,
    passages, fleets and robot shapes.
    """
    # Steps among cells given as an array (as a fleet's are): the path ahead meeting a robot,
    # and held up until the robot searches its way round.
    occ = np.zeros((12, 16), dtype=np.int8)
    occ[6, :11] = 1
    on_map = grid_map(occ, resolution=0.1)
    for whole in (False, True):  # a goal's search, and the whole-map wave it hands over to
        for patience, cells in ((3, [[3, 6]]), (0, [[3, 2], [4, 2], [2, 2], [4, 1], [2, 1]])):
            p = plan(on_map, (3, 1), (9, 1), robot_radius=0.1, patience=patience, whole=whole)
            session = Session(p)
            for _ in range(3):
                session.step(np.array(cells, dtype=np.int64))
    if served is not None:
        served()
    for writeable in (False, True):
        grid = np.zeros((6, 6), dtype=np.uint8)
        grid[2, 1:5] = 1
        grid[4, 3] = 1
        grid.flags.writeable = writeable
        for preset in ("wide", "wfs-mmas", "mmas"):
            p = plan(grid, (0, 0), (5, 5), preset=preset, patience=0)
            _ = plan(grid, (0, 0), (5, 5), preset=preset, whole=True).path  # a service's plans
            p.analysis.gate_cells()
            _ = p.min_clearance
            run_episode(p, dynamic_count=2, seed=0, max_steps=4)
            run_episode(p, dynamic_count=2, seed=0, max_steps=4, obstacle_motion="simultaneous")
            Session(p).step()  # a move, and the path ahead's kernels
            session = Session(p)
            # Held up (the replan kernel), by cells given as an array (as a fleet's are).
            session.step(np.array([[0, 1], [1, 0], [1, 1]], dtype=np.int64))
    # The passages' kernels: two rooms and a door between them.
    rooms = np.zeros((9, 9), dtype=np.int8)
    rooms[:, 4] = 1
    rooms[4, 4] = 0
    find_passages(grid_map(rooms, resolution=0.1), robot_radius=0.05, max_width=0.3)
    # A fleet: its roadmap (chains and lattice), a start joining it, and a joint plan on it.
    p = plan(on_map, (3, 1), (9, 1), robot_radius=0.1)
    roadmap = build_roadmap(p.analysis, radius=0.1)
    attach(roadmap, p.analysis, (3, 1), exclude=[0])
    # A limit far above the solve's: one hit while compiling would skip the search's kernels,
    # left uncompiled (and out of numba's cache) for the next start to compile.
    solve(roadmap, [0, roadmap.nodes - 1], [roadmap.nodes - 1, 0], time_limit_s=3600.0)
    # Robot shapes: a footprint turning in place, and a car searched for, on a robot map.
    box = [[0.1, 0.05], [0.1, -0.05], [-0.1, -0.05], [-0.1, 0.05]]
    ends = {"x": 0.25, "y": 0.25, "yaw": 0.0}, {"x": 1.25, "y": 0.25, "yaw": 0.0}
    plan(on_map, *ends, footprint=box).poses  # noqa: B018
    plan(on_map, *ends, footprint=box, motion="car", min_turning_radius=0.2).poses  # noqa: B018

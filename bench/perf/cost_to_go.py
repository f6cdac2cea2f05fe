"""The planners' cost-to-go fields by each method, side by side: the relaxation, the Dijkstra
the package uses above :data:`~maopg.sim.planning.RELAXATION_CELLS` (its own, numpy), and
scipy's sparse-graph Dijkstra, which it used before (scipy was a core dependency for this one
call).

Run: ``.venv/bin/python bench/perf/cost_to_go.py [--repeats 5]``. Prints a Markdown block for
BENCHMARKS.md: per Water Filling room (the team sizes of ``bench/perf/wf_teams.py``) the grid,
the best of ``--repeats`` timings of one field (the vehicles' grid, jar 0) by each method, and
whether the fields are equal to the bit (a planner that moved by one ulp would change the
trajectories). scipy's import is timed on its own (a process that builds a big room paid it
once); without scipy installed its column reads ``-``.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
import sys
import time
from collections.abc import Callable

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import numpy as np

from maopg.env import make_env
from maopg.experiment.run.sysinfo import markdown
from maopg.sim.planning import dijkstra_cost_to_go, legal_moves, relaxed_cost_to_go

SIZES = ((1, 1, 3), (2, 1, 4), (4, 4, 8), (8, 8, 16))
"""(vehicles, drones, jars), as ``bench/perf/wf_teams.py``: the default team first."""


def scipy_cost_to_go(blocked: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """The package's former Dijkstra: scipy's over the legal moves, each edge reversed."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    ny, nx = blocked.shape
    ids = np.arange(ny * nx).reshape(ny, nx)
    heads, tails, lengths = [], [], []
    for di, dj, step, ok in legal_moves(blocked):
        i, j = np.nonzero(ok)
        heads.append(ids[i + di, j + dj])
        tails.append(ids[i, j])
        lengths.append(np.full(i.size, step))
    graph = coo_matrix(
        (np.concatenate(lengths), (np.concatenate(heads), np.concatenate(tails))),
        shape=(ny * nx, ny * nx),
    ).tocsr()
    sources = np.flatnonzero((seeds & ~blocked).ravel())
    return dijkstra(graph, directed=True, indices=sources, min_only=True).reshape(ny, nx)


def scipy_import_ms() -> float | None:
    """Milliseconds to import scipy's Dijkstra (``None`` without scipy)."""
    start = time.perf_counter()
    try:
        from scipy.sparse.csgraph import dijkstra  # noqa: F401
    except ImportError:
        return None
    return 1000 * (time.perf_counter() - start)


def best_ms(method: Callable, blocked: np.ndarray, seeds: np.ndarray, repeats: int):
    """The best of ``repeats`` timings (ms) and the field."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        field = method(blocked, seeds)
        times.append(1000 * (time.perf_counter() - start))
    return min(times), field


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    imported = scipy_import_ms()
    print("### Cost-to-go fields: relaxation, our Dijkstra, scipy's (`bench/perf/cost_to_go.py`)\n")
    print(markdown() + "\n")
    print(
        "| vehicles, drones, jars | grid cells | relaxation ms | Dijkstra ms "
        "| scipy's Dijkstra ms | equal to the bit |"
    )
    print("|---|---|---|---|---|---|")
    for size in SIZES:
        settings = dict(zip(("vehicles", "drones", "jars"), size, strict=True))
        env = make_env("water_filling", "continue", seed=0, overrides=settings)
        task = env.task
        grid = task.planners[0].grid
        ny, nx = grid.blocked.shape
        xs = grid.origin[0] + grid.resolution * np.arange(nx)
        ys = grid.origin[1] + grid.resolution * np.arange(ny)
        goal = task.jar_xy[0]
        seeds = np.hypot(xs[None, :] - goal[0], ys[:, None] - goal[1]) <= task.config.vehicle_reach
        env.close()
        methods = [relaxed_cost_to_go, dijkstra_cost_to_go]
        methods += [scipy_cost_to_go] if imported is not None else []
        timed = [best_ms(method, grid.blocked, seeds, args.repeats) for method in methods]
        equal = all(np.array_equal(timed[0][1], field) for _, field in timed[1:])
        cells = [f"{ms:.0f}" for ms, _ in timed] + ["-"] * (3 - len(timed))
        print(f"| {', '.join(map(str, size))} | {ny}x{nx} | {' | '.join(cells)} | {equal} |")
    shown = f"{imported:.0f} ms" if imported is not None else "not installed"
    print(
        f"\nbest of {args.repeats} per method; one field = the vehicles' grid (0.1 m cells), "
        f"jar 0. scipy's import: {shown} (once per process)."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

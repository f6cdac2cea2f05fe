"""Water Filling at several team sizes: the room each gets, what building it costs, the speed of
an episode, camera frames in the bigger rooms, and the scripted and random returns.

Run: ``.venv/bin/python bench/perf/wf_teams.py [--episodes 5]``. Prints a Markdown block for
BENCHMARKS.md.

Per size (vehicles, drones, jars): the tiles of the room and its planning grid; the build time
of the task (compiling the scene and every planner field, the part that grows with the room);
state-vector episodes of 300 ticks under ``continue`` with the scripted policy and with
uniform-random options (seeds 0..episodes-1), their mean return ± standard deviation, the return
per jar (Eq. 6 sums over the jars, so bigger teams score lower in total) and the fills; ticks/s
of the scripted episodes; ms per 64 px camera frame (every robot's camera, one reused
renderer: every drawn geom costs, and MuJoCo culls none); and the time of one cost-to-go field
(the vehicles' grid, jar 0) by each method of :func:`maopg.sim.planning.cost_to_go`.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
import sys
import time

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import numpy as np

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy, reference_policy, run_episode
from maopg.experiment.run.sysinfo import markdown
from maopg.sim.planning import dijkstra_cost_to_go, relaxed_cost_to_go
from maopg.sim.render import CameraRenderer
from maopg.tasks.water_filling.scene import read_arena

SIZES = ((1, 1, 3), (2, 1, 4), (4, 4, 8), (8, 8, 16))
"""(vehicles, drones, jars): the default team first."""
FRAMES = 200


def camera_ms(env) -> float:
    """Mean ms per 64 px frame over the robots' cameras (after one warm-up frame)."""
    task = env.task
    cameras = [r.camera_id for r in task.agent_robots]
    out = np.empty((1, 64, 64, 3), np.uint8)
    with CameraRenderer(task.scene.model, 64, 64) as renderer:
        renderer.render(task.scene.data, cameras[:1], out=out)
        start = time.perf_counter()
        for k in range(FRAMES):
            renderer.render(task.scene.data, [cameras[k % len(cameras)]], out=out)
        return 1000 * (time.perf_counter() - start) / FRAMES


def field_ms(task) -> str:
    """``relaxation / Dijkstra`` ms for the vehicles' field of jar 0."""
    grid = task.planners[0].grid
    ny, nx = grid.blocked.shape
    xs = grid.origin[0] + grid.resolution * np.arange(nx)
    ys = grid.origin[1] + grid.resolution * np.arange(ny)
    goal = task.jar_xy[0]
    seeds = np.hypot(xs[None, :] - goal[0], ys[:, None] - goal[1]) <= task.config.vehicle_reach
    times = []
    for method in (relaxed_cost_to_go, dijkstra_cost_to_go):
        start = time.perf_counter()
        method(grid.blocked, seeds)
        times.append(1000 * (time.perf_counter() - start))
    return f"{times[0]:.0f} / {times[1]:.0f}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=5)
    args = parser.parse_args(argv)
    print("### Water Filling team sizes (`bench/perf/wf_teams.py`)\n")
    print(markdown() + "\n")
    print(
        f"Episodes of 300 ticks under `continue`, seeds 0..{args.episodes - 1}, state vectors; "
        "return = mean ± std over the episodes.\n"
    )
    print(
        "| vehicles, drones, jars | tiles | grid cells | build (s) | scripted return | per jar "
        "| fills | random return | per jar | fills | scripted ticks/s | camera ms/frame "
        "| field ms (relaxation / Dijkstra) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for size in SIZES:
        settings = dict(zip(("vehicles", "drones", "jars"), size, strict=True))
        start = time.perf_counter()
        env = make_env("water_filling", "continue", seed=0, overrides=settings)
        build = time.perf_counter() - start
        task = env.task
        row = [
            ", ".join(map(str, size)),
            "x".join(map(str, read_arena(task.config).tiles)),
            "x".join(map(str, task.planners[0].grid.blocked.shape)),
            f"{build:.2f}",
        ]
        speed = 0.0
        for name in ("scripted", "random"):
            returns, fills, ticks, seconds = [], [], 0, 0.0
            for seed in range(args.episodes):
                policy = (
                    reference_policy("scripted", env)
                    if name == "scripted"
                    else RandomPolicy(env.spec, seed)
                )
                start = time.perf_counter()
                result = run_episode(env, policy, seed=seed)
                seconds += time.perf_counter() - start
                returns.append(result.ret)
                fills.append(task.fills)
                ticks += result.ticks
            if name == "scripted":
                speed = ticks / seconds
            mean = float(np.mean(returns))
            row += [
                f"{mean:,.0f} ± {np.std(returns):,.0f}",
                f"{mean / size[2]:,.0f}",
                f"{np.mean(fills):.1f}",
            ]
        row += [f"{speed:,.0f}", f"{camera_ms(env):.1f}", field_ms(task)]
        env.close()
        print("| " + " | ".join(row) + " |")
    print(
        "\nbuild = `make_env` (scene compile, occupancy grids, one cost-to-go field per jar and "
        "robot kind: by relaxation up to 20,000 grid cells, by Dijkstra above); the grid is the "
        "vehicles' (0.1 m cells). bench/perf/cost_to_go.py times the methods side by side."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

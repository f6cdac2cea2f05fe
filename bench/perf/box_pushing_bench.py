"""Box Pushing (MuJoCo) throughput: the option environment against the simulator floor.

Run: ``.venv/bin/python bench/perf/box_pushing_bench.py [--episodes N] [--size 6]``. Prints its
conditions and a Markdown table. Both sides are measured in the same run on the same compiled
model, as ``bench/perf/td_bench.py`` does for Tool Delivery:

- *env*: ``OptionEnv`` with the uniform-random reference policy, strategy ``continue`` — every
  tick's options, route planning, push judging, deliveries and observations included; ticks/s
  of low-level time (one tick = 1 s = 100 physics steps of 10 ms). Its ``Scene.advance`` (the
  physics of the episodes it plays, whose contacts — robots against boxes, walls and each
  other — cost more than an idle scene's) is timed on its own.
- *floor*: ``bench/perf/td_bench.py``'s bare physics, ``mj_step(nstep=steps per tick)`` on a fresh
  ``MjData`` of the same model (the robots idle, the boxes resting: 12 floor contacts), for the
  same number of ticks; with RGB, plus rendering exactly as many camera frames (same size,
  same fast renderer settings) as the environment rendered.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
import sys
import time

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import numpy as np

from maopg.env import DecisionPoint, OptionEnv, make_env
from maopg.env.rollout import RandomPolicy, run_episode
from maopg.experiment.run.sysinfo import markdown
from td_bench import measure_bare


def measure_env(images: bool, episodes: int, size: int) -> tuple[float, float, int, int, OptionEnv]:
    """(seconds, of which in ``Scene.advance``, ticks, camera frames rendered, env) over
    ``episodes`` random episodes."""
    env = make_env("box_pushing", "continue", seed=0, images=images, overrides={"size": size})
    policy = RandomPolicy(env.spec, 0)
    scene, advancing = env.task.scene, [0.0]
    advance = scene.advance

    def timed(seconds: float) -> None:
        start = time.perf_counter()
        advance(seconds)
        advancing[0] += time.perf_counter() - start

    scene.advance = timed  # type: ignore[method-assign]
    if images:  # the GL context outside the timing
        px = env.task.config.image_size
        env.task.render([0], np.zeros((env.spec.num_agents, px, px, 3), np.uint8))
    ticks, frames = 0, [0]

    def count(point: DecisionPoint) -> None:
        frames[0] += int(point.choosing.sum())

    start = time.perf_counter()
    for _ in range(episodes):
        ticks += run_episode(env, policy, on_step=count).ticks
    return time.perf_counter() - start, advancing[0], ticks, frames[0] if images else 0, env


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--repeats", type=int, default=3, help="alternating env/floor rounds")
    parser.add_argument("--size", type=int, default=6, help="arena side in cells")
    args = parser.parse_args(argv)
    print("### Box Pushing (MuJoCo) throughput (`bench/perf/box_pushing_bench.py`)\n")
    print(markdown() + "\n")
    print(
        f"- {args.size}x{args.size} cells, 2 Turtlebots, {args.episodes} uniform-random episodes "
        f"per round (horizon 100), strategy `continue`, 64 px cameras; env and floor measured "
        f"alternately, {args.repeats} rounds, medians shown\n"
    )
    print(
        "| observations | ticks | frames | env ticks/s | floor ticks/s | env ms/tick "
        "| of which physics | floor ms/tick | env / floor |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for images in (False, True):
        env_times, physics_times, floor_times = [], [], []
        for _ in range(args.repeats):
            env_s, physics_s, ticks, frames, env = measure_env(images, args.episodes, args.size)
            floor_times.append(measure_bare(env, ticks, frames))
            env_times.append(env_s)
            physics_times.append(physics_s)
            env.close()
        env_s, floor_s = float(np.median(env_times)), float(np.median(floor_times))
        physics_s = float(np.median(physics_times))
        label = "RGB (2 cameras)" if images else "5-bit vectors"
        print(
            f"| {label} | {ticks} | {frames} | {ticks / env_s:,.0f} | {ticks / floor_s:,.0f} "
            f"| {env_s / ticks * 1e3:.2f} | {physics_s / ticks * 1e3:.2f} "
            f"| {floor_s / ticks * 1e3:.2f} | {env_s / floor_s:.2f} |"
        )
    print(
        "\nfloor = bare `mj_step` on an idle copy of the model (+ the same number of frames "
        "rendered); physics = the env's own `Scene.advance`, contacts of its episodes included."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Tool Delivery throughput: the option environment against bare physics (and rendering).

Run: ``.venv/bin/python bench/perf/td_bench.py [--episodes N]``. Prints a Markdown block for
BENCHMARKS.md. Both sides are measured in the same run on the same compiled model:

- *env*: ``OptionEnv`` with the uniform-random reference policy, ``continue`` strategy — every
  tick's options, rules, reward and observations included; ticks/s of low-level time.
- *bare*: ``mj_step(nstep=steps per tick)`` on a fresh ``MjData`` of the same model, for the
  same number of ticks; with RGB, plus rendering exactly as many camera frames (same size,
  same renderer settings) as the environment rendered.

Target (issue 3): the option/task layer adds at most 25% over bare physics.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
import time

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy
from maopg.sim.render import CameraRenderer
from maopg.experiment.run.sysinfo import markdown


def measure_env(images: bool, episodes: int, seed: int = 0) -> tuple[float, int, int, object]:
    """(seconds, ticks, camera frames rendered, env) over ``episodes`` random episodes."""
    env = make_env("tool_delivery", "continue", seed=seed, images=images)
    policy = RandomPolicy(env.spec, seed)
    ticks = frames = 0
    start = time.perf_counter()
    for _ in range(episodes):
        point = env.reset()
        frames += int(point.choosing.sum())
        while not point.done:
            point = env.step(policy(point))
            frames += int(point.choosing.sum())
        ticks += point.ticks
    elapsed = time.perf_counter() - start
    return elapsed, ticks, (frames if images else 0), env


def measure_bare(env, ticks: int, frames: int) -> float:
    """Seconds for the same physics (and the same number of camera frames) without the env."""
    task = env.task
    model = task.scene.model
    data = mujoco.MjData(model)
    nstep = round(task.tick_seconds / model.opt.timestep)
    cameras = [robot.camera_id for robot in task.agent_robots]
    size = task.config.image_size
    renderer = CameraRenderer(model, size, size) if frames else None
    out = np.empty((1, size, size, 3), np.uint8)
    per_tick = frames / ticks if ticks else 0.0
    owed = 0.0
    start = time.perf_counter()
    for k in range(ticks):
        mujoco.mj_step(model, data, nstep=nstep)
        owed += per_tick
        while owed >= 1.0:
            renderer.render(data, [cameras[k % len(cameras)]], out=out)
            owed -= 1.0
    elapsed = time.perf_counter() - start
    if renderer is not None:
        renderer.close()
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3, help="alternating env/bare rounds")
    args = parser.parse_args()
    print("### Tool Delivery throughput (`bench/perf/td_bench.py`)\n")
    print(markdown())
    print(
        f"- {args.episodes} uniform-random episodes per round, strategy `continue`, 64 px "
        f"cameras; env and bare measured alternately, {args.repeats} rounds, medians shown\n"
    )
    print(
        "| observations | ticks | frames | env ticks/s | bare ticks/s | env ms/tick "
        "| bare ms/tick | overhead | target ≤ 25% |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for images in (False, True):
        env_times, bare_times = [], []
        for _ in range(args.repeats):
            env_s, ticks, frames, env = measure_env(images, args.episodes)
            bare_times.append(measure_bare(env, ticks, frames))
            env_times.append(env_s)
            env.close()
        env_s, bare_s = float(np.median(env_times)), float(np.median(bare_times))
        overhead = env_s / bare_s - 1
        label = "RGB (3 cameras)" if images else "state vectors"
        print(
            f"| {label} | {ticks} | {frames} | {ticks / env_s:,.0f} | {ticks / bare_s:,.0f} "
            f"| {env_s / ticks * 1e3:.3f} | {bare_s / ticks * 1e3:.3f} "
            f"| {overhead * 100:+.0f}% | {'met' if overhead <= 0.25 else 'NOT met'} |"
        )


if __name__ == "__main__":
    main()

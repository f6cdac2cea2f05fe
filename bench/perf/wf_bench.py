"""Water Filling benchmark: ticks/s of the task with RGB observations for both robots, next to
bare physics plus bare rendering of the same frames, measured in the same run.

Run: ``.venv/bin/python bench/perf/wf_bench.py``. Prints a Markdown block for BENCHMARKS.md.

For each setting the task runs ``--ticks`` ticks (episodes of 300) with 64 px images; the
frames it rendered are counted (the cameras of the choosing agents at every decision point).
The bare reference, on the same compiled model: ``mj_step`` for the same simulated time, and a
reused fast ``mujoco.Renderer`` rendering the same number of frames from the robots' cameras.
``Scene.advance`` (the sim core, which runs the drone's 50 Hz Python controller inside the
tick) is timed separately, so the table shows where the overhead comes from.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
import sys
import time

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np

from maopg.env import make_env
from maopg.env.rollout import reference_policy
from maopg.sim.render import CameraRenderer
from maopg.experiment.run.sysinfo import markdown

SETTINGS = (
    ("primitive", "random"),
    ("continue", "scripted"),
    ("continue", "random"),
    ("any", "random"),
)


def run_task(strategy: str, policy: str, ticks: int, size: int) -> tuple[float, int, int]:
    """(seconds, ticks, frames) of the task driven by ``policy`` for at least ``ticks``."""
    env = make_env("water_filling", strategy, images=True, image_size=size, seed=0)
    pol = reference_policy(policy, env, 0)
    env.reset(seed=0)
    env.task.render([0, 1], np.zeros((2, size, size, 3), np.uint8))  # GL context outside timing
    done, frames, episode = 0, 0, 0
    start = time.perf_counter()
    while done < ticks:
        point = env.reset(seed=episode)
        frames += int(point.choosing.sum())
        while not point.done:
            point = env.step(pol(point))
            frames += int(point.choosing.sum())
        done += point.ticks
        episode += 1
    elapsed = time.perf_counter() - start
    env.close()
    return elapsed, done, frames


def bare(ticks: int, frames: int, size: int) -> tuple[float, float, float]:
    """(s of mj_step, s of rendering ``frames``, s of Scene.advance) on the task's own model."""
    env = make_env("water_filling", "continue", images=True, image_size=size)
    task = env.task
    scene = task.scene
    model, data = scene.model, mujoco.MjData(scene.model)
    nstep = round(task.tick_seconds / scene.timestep)
    mujoco.mj_forward(model, data)
    start = time.perf_counter()
    for _ in range(ticks):
        mujoco.mj_step(model, data, nstep=nstep)
    physics = time.perf_counter() - start

    task.reset(0)
    cameras = [r.camera_id for r in task.agent_robots]
    with CameraRenderer(model, size, size) as renderer:
        out = np.empty((1, size, size, 3), np.uint8)
        renderer.render(scene.data, cameras[:1], out=out)
        start = time.perf_counter()
        for k in range(frames):
            renderer.render(scene.data, [cameras[k % 2]], out=out)
        render = time.perf_counter() - start

    start = time.perf_counter()
    for t in range(ticks):  # the robots shuttle, as options would make them
        x = 1.0 if t % 16 < 8 else -1.0
        task.vehicle.drive_to((x, 0.0))
        task.drone.fly_to((-x, 1.0, 1.5))
        scene.advance(task.tick_seconds)
    advance = time.perf_counter() - start
    env.close()
    return physics, render, advance


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ticks", type=int, default=1200)
    parser.add_argument("--size", type=int, default=64)
    args = parser.parse_args(argv)
    print("### Water Filling task (`bench/perf/wf_bench.py`)\n")
    print(markdown() + "\n")
    print(
        f"{args.size} px RGB observations for both robots (rendered for the choosing robots at "
        "each decision point); tick = 0.5 s = 100 physics steps of 5 ms.\n"
    )
    print(
        "| strategy | policy | ticks | frames/tick | task ticks/s | bare physics+render "
        "ticks/s | overhead | of which Scene.advance |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for strategy, policy in SETTINGS:
        t_task, ticks, frames = run_task(strategy, policy, args.ticks, args.size)
        t_phys, t_render, t_adv = bare(ticks, frames, args.size)
        t_bare = t_phys + t_render
        print(
            f"| {strategy} | {policy} | {ticks} | {frames / ticks:.2f} | {ticks / t_task:,.0f} "
            f"| {ticks / t_bare:,.0f} | {100 * (t_task / t_bare - 1):+.0f}% "
            f"| {100 * (t_adv - t_phys) / t_bare:+.0f}% |"
        )
    print(
        "\noverhead = task time / (bare mj_step + bare render) − 1; the last column is the part "
        "of it spent in `Scene.advance` beyond bare `mj_step` (the drone's cascaded controller, "
        "run in Python at 50 Hz by the sim core)."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

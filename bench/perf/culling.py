"""Observation frames drawn whole and culled to the camera's view: time per frame, same pixels?

Run: ``.venv/bin/python bench/perf/culling.py [--steps 300] [--size 64]``. Prints a Markdown block
for BENCHMARKS.md. Each task steps one environment under the uniform-random policy; at every
decision point each robot camera is drawn twice with one renderer of the observation settings
(no shadows, reflections or multisampling), whole and after
:func:`~maopg.sim.culling.cull_outside_view`, back to back, so machine load hits both alike.
A frame's time is ``update_scene`` (+ the culling) + ``mjr_render`` + the pixel read-back.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
import statistics
import time

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import numpy as np

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy, decision_points
from maopg.experiment.run.sysinfo import markdown
from maopg.sim.culling import cull_outside_view
from maopg.sim.render import make_renderer

TASKS = ("tool_delivery", "water_filling")


def measure(task: str, steps: int, size: int) -> dict[str, float]:
    env = make_env(task, seed=0)
    scene = env.task.scene
    cameras = [robot.camera_id for robot in env.task.agent_robots]
    renderer = make_renderer(scene.model, size, size, shadows=False, offsamples=0)
    whole, culled, skipped, same = [], [], [], 0
    try:
        for _ in decision_points(env, RandomPolicy(env.spec, seed=0), steps):
            for camera in cameras:
                start = time.perf_counter()
                renderer.update_scene(scene.data, camera=camera)
                plain = renderer.render().copy()
                middle = time.perf_counter()
                renderer.update_scene(scene.data, camera=camera)
                skipped.append(cull_outside_view(renderer.scene, 1.0))
                fewer = renderer.render().copy()
                end = time.perf_counter()
                whole.append(middle - start)
                culled.append(end - middle)
                same += int(np.array_equal(plain, fewer))
    finally:
        renderer.close()
        env.close()
    return {
        "frames": len(whole),
        "geoms": scene.model.ngeom,
        "skipped": statistics.mean(skipped),
        "whole": 1e3 * statistics.median(whole),
        "culled": 1e3 * statistics.median(culled),
        "same": same,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=300, help="decision points per task")
    parser.add_argument("--size", type=int, default=64, help="frame side (px)")
    args = parser.parse_args()
    print("### Observation frames culled to the view (`bench/perf/culling.py`)\n")
    print(markdown())
    print(f"- {args.steps} decision points per task, uniform-random options, {args.size} px\n")
    print(
        "| task | robot-camera frames | geoms | skipped per frame (mean) | whole (ms, median) | "
        "culled (ms, median) | culled/whole | identical frames |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for task in TASKS:
        m = measure(task, args.steps, args.size)
        print(
            f"| {task} | {m['frames']} | {m['geoms']} | {m['skipped']:.1f} | {m['whole']:.2f} | "
            f"{m['culled']:.2f} | {m['culled'] / m['whole']:.2f} | {m['same']} of {m['frames']} |"
        )


if __name__ == "__main__":
    main()

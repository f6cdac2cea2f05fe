"""What each combination of camera channels costs per robot-camera frame.

Run: ``.venv/bin/python bench/perf/camera_channels.py [--steps 100] [--size 64]``. Prints a
Markdown block for BENCHMARKS.md. Each task steps one environment under the uniform-random
policy; at every decision point each robot camera is rendered once with a renderer of every
combination (:class:`~maopg.sim.render.CameraRenderer`, the observation settings), one after
the other, so machine load hits all alike. A frame's time is everything
:meth:`~maopg.sim.render.CameraRenderer.render` does: ``update_scene``, the culling, the
pass(es), the read-back, depth's conversion to metres and segmentation's lookup of classes.
Colour and depth share one pass; segmentation is a pass of its own (``maopg.sim.render``), so
``rgb + depth`` beside ``rgb+depth`` shows what the shared pass saves over two.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
import itertools
import statistics
import time

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy, decision_points
from maopg.experiment.run.sysinfo import markdown
from maopg.sim.channels import CHANNELS, ImageChannels
from maopg.sim.render import CameraRenderer, depth_range

TASKS = ("tool_delivery", "water_filling")
COMBINATIONS = [c for n in range(1, 4) for c in itertools.combinations(CHANNELS, n)]


def measure(task: str, steps: int, size: int) -> dict[tuple[str, ...], float]:
    """Median milliseconds per frame of each combination."""
    env = make_env(task, seed=0)
    scene, classes = env.task.scene, env.task.segmentation
    cameras = [robot.camera_id for robot in env.task.agent_robots]
    renderers = {
        names: CameraRenderer(
            scene.model,
            size,
            size,
            channels=ImageChannels(
                names,
                depth_range(scene.model) if "depth" in names else None,
                classes.classes if "seg" in names else (),
            ),
            classes=classes if "seg" in names else None,
        )
        for names in COMBINATIONS
    }
    times: dict[tuple[str, ...], list[float]] = {names: [] for names in COMBINATIONS}
    try:
        for renderer in renderers.values():  # GL contexts and shaders made before timing
            renderer.render(scene.data, cameras[:1])
        for _ in decision_points(env, RandomPolicy(env.spec, seed=0), steps):
            for camera in cameras:
                for names, renderer in renderers.items():
                    start = time.perf_counter()
                    renderer.render(scene.data, [camera])
                    times[names].append(time.perf_counter() - start)
    finally:
        for renderer in renderers.values():
            renderer.close()
        env.close()
    return {names: 1e3 * statistics.median(t) for names, t in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=100, help="decision points per task")
    parser.add_argument("--size", type=int, default=64, help="frame side (px)")
    args = parser.parse_args()
    print("### Camera channels: cost per frame (`bench/perf/camera_channels.py`)\n")
    print(markdown())
    print(f"- {args.steps} decision points per task, uniform-random options, {args.size} px\n")
    print("| channels | " + " | ".join(f"{t} (ms, median)" for t in TASKS) + " |")
    print("|---|" + "---|" * len(TASKS))
    results = [measure(task, args.steps, args.size) for task in TASKS]
    for names in COMBINATIONS:
        cells = " | ".join(f"{m[names]:.2f} ({m[names] / m[('rgb',)]:.2f}x)" for m in results)
        print(f"| {'+'.join(names)} | {cells} |")
    two = [m[("rgb",)] + m[("depth",)] for m in results]
    print("| rgb, then depth (two passes) | " + " | ".join(f"{t:.2f}" for t in two) + " |")


if __name__ == "__main__":
    main()

"""What ``env.appearance`` costs: observation frames under ``off``, ``full`` and ``heldout``
side by side, and the time to show an episode's look.

Run: ``.venv/bin/python bench/perf/appearance.py [--steps 200] [--size 64] [--episodes 200]``.
Prints a Markdown block for BENCHMARKS.md. Per task, one environment per value steps under
the same seeded uniform-random policy (the looks never change the physics, so the three play
the same trajectory); at every decision point each robot camera of each is drawn by the task's
own observation renderer (``SceneTask.render``: no shadows, reflections nor multisampling,
culled to the view), the three values back to back in an order that rotates every step, so
machine load hits them alike. A frame's time is ``update_scene`` + culling + ``mjr_render`` +
the pixel read-back, on the wall clock and in the process's CPU time (every thread's, Mesa's
llvmpipe rasterises on threads of its own): the CPU time is what a frame costs, which the load
of a shared machine leaves alone, where the wall clock also counts the waits for a core
(``--rounds`` measures each task again, so the spread between rounds shows). Then
each environment is reset ``--episodes`` times: the time of
``Task.draw_appearance`` (draw the look, write it into the model, place what moved), and the
compiles counted meanwhile (``MjSpec.compile`` and ``MjModel.from_*`` wrapped to count calls)
with the model object's identity before and after.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
import itertools
import statistics
import time
from collections.abc import Callable
from typing import Any

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy, decision_points
from maopg.experiment.run.sysinfo import markdown

TASKS = ("tool_delivery", "water_filling", "box_pushing")
LEVELS = ("off", "full", "heldout")


class CompileCounter:
    """Counts the calls of MuJoCo's model compilers while it is entered."""

    NAMES = (
        (mujoco.MjSpec, "compile"),
        (mujoco.MjModel, "from_xml_path"),
        (mujoco.MjModel, "from_xml_string"),
        (mujoco.MjModel, "from_binary_path"),
    )

    def __init__(self) -> None:
        self.calls = 0
        self._saved: list[tuple[Any, str, Any]] = []

    def _counted(self, function: Callable[..., Any]) -> Callable[..., Any]:
        def counted(*args: Any, **kwargs: Any) -> Any:
            self.calls += 1
            return function(*args, **kwargs)

        return counted

    def __enter__(self) -> CompileCounter:
        for owner, name in self.NAMES:
            raw = owner.__dict__[name]
            self._saved.append((owner, name, raw))
            wrapped = self._counted(getattr(owner, name))
            setattr(
                owner, name, staticmethod(wrapped) if isinstance(raw, staticmethod) else wrapped
            )
        return self

    def __exit__(self, *exc: object) -> None:
        for owner, name, raw in self._saved:
            setattr(owner, name, raw)


def frames(task: str, steps: int, size: int) -> dict[str, dict[str, list[float]]]:
    """Per value, the wall-clock and the process's CPU seconds of every robot-camera frame
    along the same trajectory."""
    envs = {
        level: make_env(task, seed=0, images=True, image_size=size, overrides={"appearance": level})
        for level in LEVELS
    }
    times: dict[str, dict[str, list[float]]] = {level: {"wall": [], "cpu": []} for level in LEVELS}
    streams = {
        level: decision_points(env, RandomPolicy(env.spec, seed=0), steps)
        for level, env in envs.items()
    }
    n = envs["off"].num_agents
    out = np.empty((n, size, size, 3), np.uint8)
    try:
        for step, points in enumerate(zip(*streams.values(), strict=True)):
            assert all(np.array_equal(p.running, points[0].running) for p in points)
            order = LEVELS[step % 3 :] + LEVELS[: step % 3]
            for agent in range(n):
                for level in order:
                    start, cpu = time.perf_counter(), time.process_time()
                    envs[level].task.render([agent], out)
                    times[level]["cpu"].append(time.process_time() - cpu)
                    times[level]["wall"].append(time.perf_counter() - start)
    finally:
        for env in envs.values():
            env.close()
    return times


def episodes(task: str, level: str, count: int) -> dict[str, float]:
    """The first look's time (it also reads the scene), the median of the next ``count``, and
    the compiles during ``count`` resets."""
    env = make_env(task, seed=0, overrides={"appearance": level})
    task_ = env.task
    model = task_.scene.model
    start = time.perf_counter()
    task_.draw_appearance(0)
    first = time.perf_counter() - start
    times = []
    with CompileCounter() as counter:
        for seed in range(1, count + 1):
            env.reset(seed=seed)
            start = time.perf_counter()
            task_.draw_appearance(seed)
            times.append(time.perf_counter() - start)
    same = task_.scene.model is model
    env.close()
    return {
        "first": first,
        "median": statistics.median(times),
        "compiles": counter.calls,
        "same": same,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=200, help="decision points per task")
    parser.add_argument("--size", type=int, default=64, help="frame side (px)")
    parser.add_argument("--episodes", type=int, default=200, help="looks shown per value")
    parser.add_argument(
        "--rounds", type=int, default=3, help="times each task's frames are measured afresh"
    )
    args = parser.parse_args()
    print("### The cost of `env.appearance` (`bench/perf/appearance.py`)\n")
    print(markdown())
    print(
        f"- {args.steps} decision points per task in each of {args.rounds} rounds, "
        f"uniform-random options, {args.size} px frames; {args.episodes} episodes' looks per "
        "value\n"
    )
    print(
        "| task | round | clock | robot-camera frames per value | off (ms, median) | "
        "full (ms, median) | heldout (ms, median) | full/off | heldout/off |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for task, round_ in itertools.product(TASKS, range(1, args.rounds + 1)):
        measured = frames(task, args.steps, args.size)
        for clock in ("wall", "cpu"):
            t = {level: 1e3 * statistics.median(v[clock]) for level, v in measured.items()}
            print(
                f"| {task} | {round_} | {clock} | {len(measured['off'][clock])} | {t['off']:.2f} | "
                f"{t['full']:.2f} | {t['heldout']:.2f} | {t['full'] / t['off']:.3f} | "
                f"{t['heldout'] / t['off']:.3f} |"
            )
    print()
    print(
        "| task | value | first look (ms: reads the scene too) | a look per episode (µs, median) | "
        "compiles in the resets | same model object |"
    )
    print("|---|---|---|---|---|---|")
    for task in TASKS:
        for level in LEVELS[1:]:
            e = episodes(task, level, args.episodes)
            print(
                f"| {task} | {level} | {1e3 * e['first']:.1f} | {1e6 * e['median']:.0f} | "
                f"{e['compiles']} | {e['same']} |"
            )


if __name__ == "__main__":
    main()

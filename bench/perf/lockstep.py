"""What lockstep costs when option steps are uneven: why Water Filling runs one process per env.

Run: ``.venv/bin/python bench/perf/lockstep.py [--checkpoint PATH] [--envs 4] [--steps 400]``.

A vector step advances every environment to its own next decision point, which may be one tick
away or ten. A worker holding several environments steps them one after another and the step
ends when the slowest worker is done, so an uneven step leaves a core idle. This plays a trained
policy (sampled, as in training; default: the committed grid's Water Filling ``async`` seed 0,
from RGB) on ``--envs`` environments, times each environment's option steps (physics, the
option layer, the choosing robots' cameras), and computes from those times what a vector step
would take with the environments split over W workers on this machine's cores: the slowest
worker's share, but at least the whole step's work spread over the cores (the operating system
shares the cores between more workers than cores). It prints that total against the ideal (all
work spread evenly over the cores, every step). A model from measured times, not a training
run: ``bench/perf/train_speed_wf.py`` gives the verdict on the wall-clock of a whole run.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from maopg.env.vector_base import split_envs
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.sysinfo import markdown


def step_times(checkpoint: Path, envs: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Seconds and ticks ``[steps, envs]`` of each environment's option steps."""
    trained = load_trained(checkpoint)
    games = [trained.make_env(seed=e) for e in range(envs)]
    actors = [trained.actor(greedy=False, seed=e) for e in range(envs)]
    points = [env.reset(seed=e) for e, env in enumerate(games)]
    seconds, ticks = np.zeros((steps, envs)), np.zeros((steps, envs))
    for s in range(steps):
        for e, env in enumerate(games):
            joint = actors[e](points[e])
            start = time.perf_counter()
            points[e] = env.step(joint)
            seconds[s, e] = time.perf_counter() - start
            ticks[s, e] = points[e].duration
            if points[e].done:
                points[e] = env.reset(seed=envs * (s + 1) + e)
    for env in games:
        env.close()
    return seconds, ticks


def lockstep_total(seconds: np.ndarray, workers: int, cores: int) -> float:
    """Summed vector-step time with the environments split over ``workers`` (module doc)."""
    groups = split_envs(seconds.shape[1], workers)
    return float(sum(max(max(row[g].sum() for g in groups), row.sum() / cores) for row in seconds))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--checkpoint", type=Path, default=Path("results/runs/water_filling/async/seed0/final.pt")
    )
    parser.add_argument("--envs", type=int, default=4, help="environments (default %(default)s)")
    parser.add_argument("--steps", type=int, default=400, help="vector steps (default %(default)s)")
    args = parser.parse_args()
    cores = os.cpu_count() or 1
    conditions = markdown()
    seconds, ticks = step_times(args.checkpoint, args.envs, args.steps)
    ideal = seconds.sum() / cores

    print("### Lockstep over uneven option steps (`bench/perf/lockstep.py`)\n")
    print(conditions)
    print(f"- policy: `{args.checkpoint}`, sampled; {args.envs} environments × {args.steps} steps")
    print(
        f"- an option step: {1e3 * seconds.mean():.2f} ms (coefficient of variation "
        f"{seconds.std() / seconds.mean():.2f}), {ticks.mean():.2f} ticks (cv "
        f"{ticks.std() / ticks.mean():.2f})\n"
    )
    print(
        f"| workers | environments per worker | vector steps against the ideal on {cores} cores |"
    )
    print("|---|---|---|")
    for workers in sorted({1, min(2, args.envs), cores, args.envs}):
        per = "/".join(str(len(g)) for g in split_envs(args.envs, workers))
        ratio = lockstep_total(seconds, workers, cores) / ideal
        print(f"| {workers} | {per} | {ratio:.2f}× |")


if __name__ == "__main__":
    main()

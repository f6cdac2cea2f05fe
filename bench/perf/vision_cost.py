"""What the vision study costs (``python -m eval reproduce --study vision``): ``async`` from RGB
on Tool Delivery and Water Filling with ``env.appearance=off`` and ``full`` side by side, its
evaluations, and the study's projected CPU-hours.

Run: ``.venv/bin/python bench/perf/vision_cost.py [--samples td=2000,wf=4000] [--eval-episodes
1]`` (about 2.5 CPU-minutes at the defaults). Prints a Markdown block for BENCHMARKS.md.

Per task, each look trains ``async`` through the command line at the study's settings
(``images=true``, ``env.appearance``, ``env.camera_channels=rgb``; no video, no evaluation
after training) for a short budget in a scratch run directory, the two looks back to back:

- **wall s per 100K** from the run's own ``metrics.csv``, as ``train_rate.py`` reads it: samples
  over the wall clock of every iteration but the first (start-up and first renders left out);
- **CPU s per 100K**: the CPU time of this process and its children (Water Filling's
  environment worker processes) over the whole run, start-up included, per sample: an upper
  bound, since a 200K-sample run pays its start-up once.

Then the short run's final policy plays the study's evaluation
(:func:`maopg.experiment.studies.vision.policy_looks`: its own looks and the held-out ones,
``heldout`` and ``mounts``, greedy and sampled) for ``--eval-episodes`` episodes each, timed
the same two ways, per episode. An untrained policy plays Tool Delivery to its 150-tick
limit, where a trained one ends sooner: an upper bound there too (Water Filling's episodes are
always 300 ticks).

The projection multiplies out the study's cells (:data:`maopg.experiment.studies.vision.
VARIANTS`: each task's budget × seeds per variant; the depth pilots at the ``full`` RGB rate,
which they are not measured at) and its evaluations (3 looks: its own, ``heldout`` and
``mounts``, × 2 ways of acting ×
:data:`~maopg.experiment.studies.vision.EPISODES` episodes per run), in CPU-hours, and in hours
of this machine's wall clock at one cell at a time.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.append(str(Path(__file__).parents[2]))  # `train`, after PYTHONPATH (compare_checkouts)
sys.path.insert(0, str(Path(__file__).parent))  # train_rate
from train_rate import train_rate

from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.sysinfo import markdown
from maopg.experiment.studies.runs import load_run
from maopg.experiment.studies.vision import (
    ACTINGS,
    EPISODES,
    HELD_OUT_LOOKS,
    VARIANTS,
    policy_looks,
)

CASES = {"td": "tool_delivery", "wf": "water_filling"}
LOOKS = ("off", "full")


def cpu_seconds() -> float:
    """CPU time so far of this process and of its children that have ended."""
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def measure(task: str, look: str, samples: int, episodes: int) -> dict[str, float]:
    """One short run of the study's settings, then its final policy's evaluation."""
    args = ["--images", "--total-samples", str(samples), f"env.appearance={look}"]
    args += ["env.camera_channels=rgb", "eval_episodes=0", "plot=false"]
    with tempfile.TemporaryDirectory() as scratch:
        run_dir = Path(scratch) / "run"
        cpu = cpu_seconds()
        rate, iterations = train_rate(task, args, run_dir)
        train_cpu = cpu_seconds() - cpu
        trained = load_trained(run_dir / "final.pt")
        run = load_run(run_dir)
        trained_samples = float(run.samples[-1])  # an iteration may overshoot the budget
        wall, cpu = time.perf_counter(), cpu_seconds()
        played = policy_looks(trained, run, episodes)
        evaluations = len(played) * episodes
        return {
            "iterations": iterations,
            "wall": 100_000 / rate,
            "cpu": train_cpu / trained_samples * 100_000,
            "eval_wall": (time.perf_counter() - wall) / evaluations,
            "eval_cpu": (cpu_seconds() - cpu) / evaluations,
            "ticks": sum(s["length_mean"] * s["episodes"] for s in played) / evaluations,
        }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated: %(default)s")
    parser.add_argument(
        "--samples", default="td=2000,wf=4000", help="case=samples, comma-separated"
    )
    parser.add_argument("--eval-episodes", type=int, default=1, help="per look and way of acting")
    options = parser.parse_args()
    budgets = dict(item.split("=") for item in options.samples.split(","))
    command = f"bench/perf/vision_cost.py --samples {options.samples}"
    print(f"### The vision study's cost (`{command} --eval-episodes {options.eval_episodes}`)\n")
    print(markdown())
    print(
        "\n| task | env.appearance | samples asked | iterations | wall s per 100K | CPU s per 100K "
        "(start-up included) | evaluation: ticks per episode | wall s per episode | CPU s per "
        "episode |\n|---|---|---|---|---|---|---|---|---|"
    )
    figures: dict[tuple[str, str], dict[str, float]] = {}
    looks = 1 + len(HELD_OUT_LOOKS)  # a run's own looks and the held-out ones
    for case in options.cases.split(","):
        task = CASES[case]
        for look in LOOKS:
            f = measure(task, look, int(budgets[case]), options.eval_episodes)
            figures[task, look] = f
            print(
                f"| {task} | {look} | {int(budgets[case]):,} | {f['iterations']:.0f} | "
                f"{f['wall']:.0f} | {f['cpu']:.0f} | {f['ticks']:.0f} | {f['eval_wall']:.2f} | "
                f"{f['eval_cpu']:.2f} |"
            )
    print(
        f"\nProjection: each cell at its budget, then {looks * len(ACTINGS)} evaluations of "
        f"{EPISODES} episodes per run.\n\n| variant | task | runs | samples each | training "
        "CPU-hours | evaluation CPU-hours | wall hours, one cell at a time |\n"
        "|---|---|---|---|---|---|---|"
    )
    total_cpu = total_wall = 0.0
    for v in VARIANTS:
        look = "full" if v.pilot else v.name
        for study_task in v.study.tasks:
            if (study_task.task, look) not in figures:  # a case left out
                continue
            f = figures[study_task.task, look]
            runs, samples = len(study_task.seeds), study_task.overrides["total_samples"]
            episodes = runs * looks * len(ACTINGS) * EPISODES
            train_cpu = runs * samples / 100_000 * f["cpu"] / 3600
            eval_cpu = episodes * f["eval_cpu"] / 3600
            wall = (runs * samples / 100_000 * f["wall"] + episodes * f["eval_wall"]) / 3600
            total_cpu, total_wall = total_cpu + train_cpu + eval_cpu, total_wall + wall
            print(
                f"| {v.name} | {study_task.task} | {runs} | {samples:,} | {train_cpu:.1f} | "
                f"{eval_cpu:.2f} | {wall:.1f} |"
            )
    print(
        f"\nThe study: {total_cpu:.1f} CPU-hours, {total_wall:.1f} wall hours one cell at a time."
    )


if __name__ == "__main__":
    main()

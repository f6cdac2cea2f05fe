"""How often a reference policy would meet a learning-curve target if it were the policy trained.

A target such as "the final 10% of the curves reaches the scripted heuristic's return" reads a
noisy figure: each seed's final return is the mean of its last iterations' episode means, and
the target is the mean of that over seeds. Water Filling's returns spread by about 75,000 an
episode, and the final 10% of a 200K-sample run holds only about 66 episodes, so the figure
moves by thousands from one set of seeds to the next. This script plays the reference
policy's own episodes through that very measurement: for each draw, every iteration of every
run's final 10% is given as many of the reference's episode returns (drawn with replacement)
as it ended, and the draw is averaged as ``eval table`` averages a run and a group.

It prints how often the reference policy itself would read at or above the target, and the
expected return a policy with the reference's spread of returns (its readings those of the
reference, shifted) needs to read there with 50% and with 95% probability: what the target
asks of a trained policy, next to what the reference policy scores. The draws take the
reference's episodes as its distribution of returns; the standard error of their mean, printed
with it, is what that leaves out.

Run: ``.venv/bin/python bench/target_odds.py EVAL_JSON DIR[,DIR...] --target R [--draws N]``,
where ``EVAL_JSON`` is written by ``python -m eval evaluate --reference ... --json EVAL_JSON``
(fresh episodes: a ``--seed`` the runs' targets were not read on) and the run directories
give the episodes each final iteration ended (every run directory under those folders).
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

import numpy as np

from maopg.experiment.runs import RETURN, RunData, discover_runs

FINAL_FRACTION = 0.1
"""The share of a run's samples its final return averages (``maopg.experiment.runs.final``)."""


def final_episode_counts(run: RunData) -> list[int]:
    """Episodes ended by each iteration of the run's final 10% that reported a return, the
    iterations :func:`maopg.experiment.runs.final` averages."""
    in_tail = run.samples > run.samples[-1] * (1.0 - FINAL_FRACTION)
    reported = ~np.isnan(run.metrics[RETURN])
    return [int(n) for n in run.metrics["episodes"][in_tail & reported]]


def draw_measurements(
    returns: np.ndarray, counts: list[list[int]], draws: int, rng: np.random.Generator
) -> np.ndarray:
    """``draws`` readings of the target's figure with the reference's returns: per run, the
    mean over its final iterations of each iteration's mean over its episodes; then the mean
    over runs."""
    per_run = []
    for run_counts in counts:
        iteration_means = [
            rng.choice(returns, size=(draws, n), replace=True).mean(axis=1) for n in run_counts
        ]
        per_run.append(np.mean(iteration_means, axis=0))
    return np.mean(per_run, axis=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("evaluation", type=Path, help="JSON of `python -m eval evaluate --json`")
    parser.add_argument("runs", help="run directories, comma-separated: the target's runs")
    parser.add_argument("--target", type=float, required=True, help="the target return")
    parser.add_argument("--draws", type=int, default=100_000, help="readings drawn (100000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the draws (0)")
    args = parser.parse_args()
    if args.draws < 2:
        parser.error(f"--draws is a number of readings: at least 2, got {args.draws}")
    try:
        result = json.loads(args.evaluation.read_text())
        returns = np.asarray(result["per_episode"]["returns"], dtype=np.float64)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        parser.error(f"{args.evaluation} is not a JSON of `python -m eval evaluate --json`: {exc}")
    try:
        runs = discover_runs(args.runs.split(","), unfinished=True)
    except FileNotFoundError as exc:
        parser.error(str(exc))
    if not runs:
        parser.error(f"no run directory under {args.runs!r}")
    counts = [final_episode_counts(run) for run in runs]
    if not all(counts):
        parser.error("a run has no iteration with a return in its final 10%")

    readings = draw_measurements(returns, counts, args.draws, np.random.default_rng(args.seed))
    mean = float(returns.mean())
    print(
        f"- python: {platform.python_version()}, numpy: {np.__version__}\n"
        f"- draws: {args.draws:,}, seed {args.seed}\n"
        f"- reference: {result['label']} on {result['task']} ({result['strategy']}), "
        f"{returns.size} episodes reset from seed {result['seed']}: mean {mean:,.0f}, "
        f"standard deviation {returns.std():,.0f}, standard error "
        f"{returns.std() / np.sqrt(returns.size):,.0f}\n"
        f"- measurement: the mean over {len(runs)} runs of each one's final 10% ("
        + "; ".join(f"{sum(c)} episodes over {len(c)} iterations" for c in counts)
        + ")\n\n"
        f"The reference's own readings: mean {readings.mean():,.0f}, standard deviation "
        f"{readings.std():,.0f}; at or above {args.target:,.0f} in "
        f"{np.mean(readings >= args.target):.1%} of draws.\n\n"
        "| to read at or above the target with probability | expected return needed "
        "| against the reference's |\n|---|---|---|"
    )
    for q in (0.5, 0.95):
        need = args.target + mean - float(np.quantile(readings, 1.0 - q))
        print(f"| {q:.0%} | {need:,.0f} | {need - mean:+,.0f} |")


if __name__ == "__main__":
    main()

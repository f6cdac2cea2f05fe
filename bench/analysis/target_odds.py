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

Run: ``.venv/bin/python bench/analysis/target_odds.py EVAL_JSON DIR[,DIR...] --target R
[--draws N]``, where ``EVAL_JSON`` is written by ``python -m eval evaluate --reference ...
--json EVAL_JSON`` (fresh episodes: a ``--seed`` the runs' targets were not read on) and the
run directories give the episodes each final iteration ended (every run directory under those
folders).
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

import numpy as np

from maopg.experiment.studies.runs import RunData, discover_runs, final_iterations


def final_episode_counts(run: RunData) -> list[int]:
    """Episodes ended by each iteration the run's final return averages."""
    return [int(n) for n in run.column("episodes")[final_iterations(run)]]


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


def draw_mean_errors(returns: np.ndarray, draws: int, rng: np.random.Generator) -> np.ndarray:
    """``draws`` bootstrap errors of the reference's mean (a resample's mean minus the mean):
    added to the readings, they fold in that the reference's expected return is itself only
    measured, over ``returns.size`` episodes. Drawn in chunks to bound the memory."""
    chunk = max(1, 5_000_000 // returns.size)
    errors = [
        rng.choice(returns, size=(min(chunk, draws - start), returns.size)).mean(axis=1)
        for start in range(0, draws, chunk)
    ]
    return np.concatenate(errors) - returns.mean()


def _read_evaluation(path: Path) -> tuple[dict, np.ndarray]:
    """The summary and the per-episode returns of a ``python -m eval evaluate --json`` file."""
    try:
        result = json.loads(path.read_text())
        summary = {key: result[key] for key in ("label", "task", "strategy", "seed")}
        returns = np.asarray(result["per_episode"]["returns"], dtype=np.float64)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SystemExit(
            f"error: {path} is not a JSON of `python -m eval evaluate --json`: "
            f"{type(exc).__name__}: {exc}"
        ) from None
    if returns.ndim != 1 or returns.size < 2 or not np.all(np.isfinite(returns)):
        raise SystemExit(f"error: {path} holds no list of at least 2 finite episode returns")
    return summary, returns


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
    if not np.isfinite(args.target):
        parser.error(f"--target is a return: a finite number, got {args.target}")
    reference, returns = _read_evaluation(args.evaluation)
    try:
        runs = discover_runs(args.runs.split(","), unfinished=True)
    except (OSError, ValueError) as exc:
        raise SystemExit(f"error: {exc}") from None
    if not runs:
        raise SystemExit(f"error: no run directory under {args.runs!r}")
    if other := sorted({run.task for run in runs} - {reference["task"]}):
        raise SystemExit(
            f"error: the reference played {reference['task']}, the runs {', '.join(other)}"
        )
    counts = [final_episode_counts(run) for run in runs]
    if empty := [str(run.path) for run, c in zip(runs, counts, strict=True) if not c]:
        raise SystemExit(f"error: no iteration with a return in the final 10% of {empty[0]}")

    rng = np.random.default_rng(args.seed)
    readings = draw_measurements(returns, counts, args.draws, rng)
    measured = readings + draw_mean_errors(returns, args.draws, rng)
    mean, error = float(returns.mean()), float(returns.std() / np.sqrt(returns.size))
    print(
        f"- python: {platform.python_version()}, numpy: {np.__version__}\n"
        f"- draws: {args.draws:,}, seed {args.seed}\n"
        f"- reference: {reference['label']} on {reference['task']} ({reference['strategy']}), "
        f"{returns.size} episodes reset from seed {reference['seed']}: mean {mean:,.0f}, "
        f"standard deviation {returns.std():,.0f}, standard error {error:,.0f}\n"
        f"- target: {args.target:,.0f}, {args.target - mean:+,.0f} against the reference's mean\n"
        f"- measurement: the mean over the runs of each one's final 10% (runs: {len(runs)}, "
        f"{sum(map(sum, counts)):,} episodes; "
        + "; ".join(f"{sum(c)} episodes over {len(c)} iterations" for c in counts)
        + ")\n\n"
        f"The reference's own readings: mean {readings.mean():,.0f}, standard deviation "
        f"{readings.std():,.0f}; at or above {args.target:,.0f} in "
        f"{np.mean(readings >= args.target):.1%} of draws, and in "
        f"{np.mean(measured >= args.target):.1%} with the uncertainty of the reference's "
        "mean folded in.\n\n"
        "| to read at or above the target with probability | expected return needed "
        "| against the reference's mean (± its standard error) |\n|---|---|---|"
    )
    for q in (0.5, 0.95):
        need = args.target + mean - float(np.quantile(readings, 1.0 - q))
        print(f"| {q:.0%} | {need:,.0f} | {need - mean:+,.0f} ± {error:,.0f} |")


if __name__ == "__main__":
    main()

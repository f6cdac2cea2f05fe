"""Figures of logged runs that ``python -m eval table`` does not print: how far each PPO update
moved the policy, whether two groups' final returns differ beyond their seeds' noise, and how
often a run sat at one return.

Run: ``.venv/bin/python bench/analysis/run_stats.py LABEL=DIR[,DIR...] ... [--last 10] [--at -150]
[--blocks 10]``.
Each ``LABEL=DIR,...`` is a group: every run directory under those folders (finished or not).
Prints a Markdown table per group and seed, then each group's mean ± std over seeds:

- final return: the mean over the last 10% of the run's samples (as ``eval table``);
- ``approx_kl``, ``clip_fraction`` and ``entropy``: means over the run's last ``--last``
  iterations, the size of its late updates and how sure its late policy still is (``n/a``
  for a Mac-DQN run, which logs no PPO update; a group's spread says how many seeds it has);
- with ``--at R``: the share of iterations that ended an episode whose mean return is exactly
  ``R``, and the iterations above it;
- with ``--blocks N``: then a table of each run's mean return over consecutive blocks of ``N``
  iterations, the last block ending at the last iteration, to see where a curve levels off.

Then, for the first group against each other one, the difference of the final returns' means
and its Welch standard error, ``sqrt(s1²/n1 + s2²/n2)`` with the seeds' sample variances.

``eval table`` groups runs by what they learnt from, so it pools runs of the same settings that
differ only in where they ran (a benchmark's and the grid's, say): here the groups are named.
"""

from __future__ import annotations

import argparse
import math
import statistics

import numpy as np

from maopg.experiment.studies.runs import RETURN, RunData, discover_runs, final


def _group(spec: str) -> tuple[str, list[RunData]]:
    label, sep, dirs = spec.partition("=")
    if not sep or not dirs:
        raise SystemExit(f"error: a group is LABEL=DIR[,DIR...], got {spec!r}")
    try:
        runs = discover_runs(dirs.split(","), unfinished=True)
    except (OSError, ValueError) as exc:  # a missing folder, an unreadable run
        raise SystemExit(f"error: {exc}") from None
    if not runs:
        raise SystemExit(f"error: no run directory under {dirs!r}")
    return label, runs


LATE = ("approx_kl", "clip_fraction", "entropy")
"""The columns averaged over a run's last ``--last`` iterations."""


def _late(run: RunData, column: str, last: int) -> float:
    """The column's mean over the run's last ``last`` iterations; ``nan`` for a run that does
    not log it (Mac-DQN has no PPO update to measure)."""
    values = run.metrics.get(column, np.array([]))[-last:]
    return float(np.nanmean(values)) if np.any(~np.isnan(values)) else math.nan


def _spread(values: list[float], form: str) -> str:
    """Mean ± standard deviation over the seeds that have the figure (population, as ``eval
    table`` writes it), saying how many have it when some do not; ``n/a`` where none has it."""
    known = _known(values)
    if not known:
        return "n/a"
    spread = f"{statistics.mean(known):{form}} ± {statistics.pstdev(known):{form}}"
    return spread if len(known) == len(values) else f"{spread} ({len(known)} of {len(values)})"


def _figure(value: float, form: str) -> str:
    return "n/a" if math.isnan(value) else f"{value:{form}}"


def _known(values: list[float]) -> list[float]:
    """The figures a run has: a run with no iteration in reach (an empty ``metrics.csv``, a
    Mac-DQN run's PPO columns) gives ``nan``."""
    return [value for value in values if not math.isnan(value)]


def _print_blocks(groups: list[tuple[str, list[RunData]]], size: int) -> None:
    """Each run's mean return over blocks of ``size`` iterations, aligned to its end, with the
    samples at each block's end."""
    print(f"\n| group | seed | mean return of each {size} iterations (samples at the end) |")
    print("|---|---|---|")
    for label, runs in groups:
        for run in runs:
            returns, samples = run.metrics[RETURN], run.samples
            ends = range(len(returns), 0, -size)[::-1]
            blocks = [
                f"{int(samples[end - 1]):,}: {np.nanmean(returns[max(end - size, 0) : end]):,.0f}"
                for end in ends
            ]
            print(f"| {label} | {run.seed} | {', '.join(blocks)} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("groups", nargs="+", help="LABEL=DIR[,DIR...]")
    parser.add_argument("--last", type=int, default=10, help="late iterations (default 10)")
    parser.add_argument("--at", type=float, help="a return to count iterations at")
    parser.add_argument("--blocks", type=int, help="iterations per block of the block means")
    args = parser.parse_args()
    for name in ("last", "blocks"):
        if (value := getattr(args, name)) is not None and value < 1:
            parser.error(f"--{name} is a number of iterations: at least 1, got {value}")
    groups = [_group(spec) for spec in args.groups]

    header = "| group | seed | final return (last 10%) |" + "".join(f" {c} |" for c in LATE)
    header += (
        " iterations at the return | above it (samples: return) |" if args.at is not None else ""
    )
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    finals: dict[str, list[float]] = {}
    for label, runs in groups:
        finals[label] = [final(run) for run in runs]
        late = [[_late(run, c, args.last) for c in LATE] for run in runs]
        for run, run_final, run_late in zip(runs, finals[label], late, strict=True):
            row = [label, str(run.seed), _figure(run_final, ",.0f")]
            row += [_figure(value, ".4f") for value in run_late]
            if args.at is not None:
                logged = run.metrics[RETURN]  # as logged: a smoothed curve's sums blur it
                seen = ~np.isnan(logged)
                samples, returns = run.samples[seen], logged[seen]
                at = float(np.mean(returns == args.at)) if returns.size else math.nan
                above = [
                    f"{int(s):,}: {r:,.1f}"
                    for s, r in zip(samples, returns, strict=True)
                    if r > args.at
                ]
                row += [f"{at:.1%} of {returns.size}", ", ".join(above) or "none"]
            print("| " + " | ".join(row) + " |")
        row = [f"**{label}**", f"{len(runs)} seeds", _spread(finals[label], ",.0f")]
        row += [_spread(list(values), ".4f") for values in zip(*late, strict=True)]
        print("| " + " | ".join(row + [""] * (2 if args.at is not None else 0)) + " |")

    if args.blocks is not None:
        _print_blocks(groups, args.blocks)

    first, base = next(iter(finals.items()))
    base = _known(base)
    for label, group_finals in list(finals.items())[1:]:
        values = _known(group_finals)
        if min(len(base), len(values)) < 2:
            continue
        diff = statistics.mean(base) - statistics.mean(values)
        error = math.sqrt(
            statistics.variance(base) / len(base) + statistics.variance(values) / len(values)
        )
        print(
            f"\n{first} − {label}: final returns' means differ by {diff:,.0f}, "
            f"Welch standard error {error:,.0f}"
        )


if __name__ == "__main__":
    main()

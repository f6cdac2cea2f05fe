"""Each run's value at T, seed by seed: which seeds make a mean over seeds miss its published
interval, where the studies' tables print only the mean (``published_seeds.py`` prints the
published runs' seeds the same way).

Run: ``.venv/bin/python bench/analysis/seed_values.py DIR [DIR ...] --at 80000,100000,150000
[--counter published_steps] [--every-rounds 6]``. Every run directory under the ``DIR``
folders, finished or not, gives one row: its value at each T (reference §9: the mean of its
last 5 evaluations logged at or before T on ``--counter``; maopg's ``samples`` by default,
``published_steps`` the counter of ACAC's and MacroMARL's logs), ``—`` where it has not trained
that far or does not log the counter; a last row gives the mean over the runs where there are
several.

``--every-rounds K`` reads a round learner's evaluations (ACAC's, MacroMARL's: one iteration
is one round) at the published cadence: only the last evaluation logged in each block of K
rounds. ACAC's published runs evaluate every 96 episodes of their counter, every 6th round of
16 (reference §8), where maopg's evaluate every 2,000 of its samples, a round or two apart:
their last 5 span a wider stretch of training than maopg's.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics

import numpy as np
from runs_at import label, runs_at

from maopg.experiment.studies.published import EVAL_RETURN, value_at
from maopg.experiment.studies.runs import RunData


def every_rounds(run: RunData, k: int) -> RunData:
    """``run`` with only the last evaluation of each block of ``k`` iterations (rounds) kept."""
    values = run.column(EVAL_RETURN)
    block = (run.column("iteration").astype(np.int64) - 1) // k
    kept = np.full_like(values, np.nan)
    for b in np.unique(block):
        logged = np.flatnonzero((block == b) & ~np.isnan(values))
        if logged.size:
            kept[logged[-1]] = values[logged[-1]]
    return dataclasses.replace(run, metrics={**run.metrics, EVAL_RETURN: kept})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--every-rounds", type=int, default=1, metavar="K")
    runs, points, counter, args = runs_at(__doc__, parser)
    k = args.every_rounds
    if k < 1:
        parser.error(f"--every-rounds must be a positive integer, got {k}")
    cadence = "" if k == 1 else f", every {k} rounds"
    print(f"Counter: {counter}{cadence}; a run's value at T: the mean of its last 5 evaluations\n")
    print("| run | " + " | ".join(f"{t / 1000:g}K" for t in points) + " |")
    print("|" + "---|" * (len(points) + 1))
    table = []
    for run in runs:
        values = [value_at(every_rounds(run, k), t, counter=counter) for t in points]
        table.append(values)
        cells = ["—" if math.isnan(v) else f"{v:.1f}" for v in values]
        print(f"| {label(run)} | " + " | ".join(cells) + " |")
    if len(table) > 1:
        means = [statistics.fmean(column) for column in zip(*table, strict=True)]
        cells = ["—" if math.isnan(v) else f"{v:.2f}" for v in means]
        print("| mean over the runs | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()

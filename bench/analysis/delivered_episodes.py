"""How many of a run's training episodes succeeded (on Box Pushing: delivered the big box), up
to each of a few points of its curve: what exploration put in front of the learner, where an
evaluation curve says only what the policy learnt from it.

Run: ``.venv/bin/python bench/analysis/delivered_episodes.py DIR [DIR ...] --at 60000,200000
[--counter published_steps]``. Every run directory under the ``DIR`` folders (finished or not)
gives one row: per point T, the training episodes that ended by T on ``--counter`` (maopg's
``samples`` by default; ``published_steps`` is the counter of ACAC's and MacroMARL's logs) and
how many of them succeeded (each iteration's ``episodes`` times its ``success_rate``), then
the same between consecutive points.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from maopg.experiment.studies.runs import discover_runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("dirs", nargs="+", type=Path)
    parser.add_argument("--at", required=True, help="points T, comma-separated")
    parser.add_argument("--counter", default="samples")
    args = parser.parse_args()
    points = [int(t) for t in args.at.split(",")]
    header = ["run"]
    for k, t in enumerate(points):
        since = f"{points[k - 1] // 1000}K–" if k else "to "
        header.append(f"{since}{t // 1000}K: episodes, succeeded")
    print(f"Counter: {args.counter}\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for run in discover_runs(args.dirs):
        steps = run.column(args.counter)
        episodes = run.column("episodes")
        succeeded = episodes * np.nan_to_num(run.column("success_rate"))
        cells, start = [f"{run.task} {run.method} seed{run.seed}"], -np.inf
        for t in points:
            window = (steps > start) & (steps <= t)
            cells.append(f"{episodes[window].sum():.0f}, {succeeded[window].sum():.0f}")
            start = t
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()

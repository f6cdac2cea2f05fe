"""Each run's value at T, seed by seed: which seeds make a mean over seeds miss its published
interval, where the studies' tables print only the mean (``published_seeds.py`` prints the
published runs' seeds the same way).

Run: ``.venv/bin/python bench/analysis/seed_values.py DIR [DIR ...] --at 80000,100000,150000
[--counter published_steps]``. Every run directory under the ``DIR`` folders, finished or not,
gives one row: its value at each T (reference §9: the mean of its last 5 evaluations logged at
or before T on ``--counter``; maopg's ``samples`` by default, ``published_steps`` the counter of
ACAC's and MacroMARL's logs), ``—`` where it has not trained that far or does not log the
counter.
"""

from __future__ import annotations

import math

from runs_at import label, runs_at

from maopg.experiment.studies.published import value_at


def main() -> None:
    runs, points, counter = runs_at(__doc__)
    print(f"Counter: {counter}; each run's value at T (the mean of its last 5 evaluations)\n")
    print("| run | " + " | ".join(f"{t / 1000:g}K" for t in points) + " |")
    print("|" + "---|" * (len(points) + 1))
    for run in runs:
        values = [value_at(run, t, counter=counter) for t in points]
        cells = ["—" if math.isnan(v) else f"{v:.1f}" for v in values]
        print(f"| {label(run)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()

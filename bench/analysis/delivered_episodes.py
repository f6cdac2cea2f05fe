"""How many of a run's training episodes succeeded (on Box Pushing: delivered the big box), in
windows of its curve: what exploration put in front of the learner, where an evaluation curve
says only what the policy learnt from it.

Run: ``.venv/bin/python bench/analysis/delivered_episodes.py DIR [DIR ...] --at 60000,200000
[--counter published_steps]``. Every run directory under the ``DIR`` folders, finished or not,
gives one row: per window — up to the first point T, then between consecutive points — the
training episodes that ended in it on ``--counter`` (maopg's ``samples`` by default;
``published_steps`` is the counter of ACAC's and MacroMARL's logs) and how many of them
succeeded (each iteration's ``episodes`` times its ``success_rate``); ``—`` for a run that does
not log the counter.
"""

from __future__ import annotations

import numpy as np
from runs_at import label, runs_at

from maopg.experiment.studies.runs import RunData


def windows(run: RunData, counter: str, points: list[int]) -> list[str]:
    """``episodes, succeeded`` in each window of ``points`` on ``counter``."""
    try:
        steps = run.counted(counter)
    except KeyError:
        return ["—"] * len(points)
    episodes = run.column("episodes")
    succeeded = episodes * np.nan_to_num(run.column("success_rate"))
    cells = []
    for start, end in zip([-np.inf, *points[:-1]], points, strict=True):
        inside = (steps > start) & (steps <= end)
        cells.append(f"{episodes[inside].sum():.0f}, {succeeded[inside].sum():.0f}")
    return cells


def main() -> None:
    runs, points, counter, _ = runs_at(__doc__)
    labels = [f"{t / 1000:g}K" for t in points]
    header = ["run", *(f"{a}–{b}" for a, b in zip(["0", *labels[:-1]], labels, strict=True))]
    print(f"Counter: {counter}; each window: training episodes, how many succeeded\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for run in runs:
        cells = [label(run), *windows(run, counter, points)]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()

"""What the studies' runs cost: the wall time each finished run logged, per study and method,
and what the cells still to train would take at that rate.

Run: ``.venv/bin/python bench/analysis/study_cost.py [STUDY ...]`` (default: the Box Pushing
studies). Prints its BENCHMARKS.md section (``bench/run_all.sh``), one Markdown table: per
study and method, the finished runs, their wall time (the ``wall_time`` of a run's last logged
row: training, its evaluations and checkpoints, resumed runs included, start-up left out) as
mean and range in minutes, and the cells not finished with the hours they would take at the
method's mean (:func:`rows` says where a rate is lent; ``?``: no rate to project).

The runs shared a 2-core machine with one or two other runs and, at times, tests or
benchmarks, and were paused while the test suite ran, so the wall time of one run is an upper
bound on its CPU time and varies with the load; the range says by how much (a run's
``samples_per_s`` column gives its rate iteration by iteration).
"""

from __future__ import annotations

import argparse
import statistics

from maopg.experiment.studies import get_study
from maopg.experiment.studies.runs import discover_runs

BOX_PUSHING = (
    "box-pushing-6",
    "box-pushing-8",
    "box-pushing-10",
    "box-pushing-mujoco",
    "box-pushing-mujoco-rgb",
)


def minutes_by_method(names: list[str]) -> dict[tuple[str, str, str], list[float]]:
    """(study, task, method) → the wall time in minutes of each finished run."""
    found: dict[tuple[str, str, str], list[float]] = {}
    for name in names:
        root = get_study(name).runs_dir()
        for run in discover_runs([root]) if root.exists() else []:
            if run.finished:
                key = (name, run.task, run.method)
                found.setdefault(key, []).append(float(run.column("wall_time")[-1]) / 60)
    return found


def rows(names: list[str]) -> list[list[str]]:
    """One row per study and method: runs, wall time, cells left and the hours they would take
    (at the method's mean on this study's task, or, marked ≈, in the other studies given that
    run the same task: the grid's sizes lend each other their rates)."""
    minutes = minutes_by_method(names)
    out = []
    for name in names:
        study = get_study(name)
        for method in study.methods:
            cells = sum(len(task.seeds) for task in study.tasks)
            mine = [m for task in study.tasks for m in minutes.get((name, task.task, method), [])]
            left = cells - len(mine)
            spent = (
                f"{statistics.fmean(mine):.0f} ({min(mine):.0f}–{max(mine):.0f})" if mine else "—"
            )
            lent = [
                m
                for (other, task, meth), values in minutes.items()
                for m in values
                if meth == method and other != name and any(t.task == task for t in study.tasks)
            ]
            if not left:
                projected = "0.0"
            elif mine:
                projected = f"{left * statistics.fmean(mine) / 60:.1f}"
            elif lent:
                projected = f"≈ {left * statistics.fmean(lent) / 60:.1f}"
            else:
                projected = "?"
            out.append([name, method, f"{len(mine)}/{cells}", spent, str(left), projected])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("studies", nargs="*", default=list(BOX_PUSHING))
    args = parser.parse_args()
    header = [
        "study",
        "method",
        "finished",
        "minutes a run: mean (range)",
        "cells left",
        "hours left at the mean",
    ]
    print("### What the Box Pushing studies' runs took (`bench/analysis/study_cost.py`)\n")
    print(
        "Read from the runs committed under `results/<study>/runs`: the wall time each finished\n"
        "run logged, on this 2-core machine shared with one or two other runs and paused while\n"
        "the test suite ran (an upper bound on a run's CPU time), and the hours the cells left\n"
        "would take at each method's mean (≈: the rate of the same method on another size of the\n"
        "grid).\n"
    )
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for row in rows(args.studies):
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()

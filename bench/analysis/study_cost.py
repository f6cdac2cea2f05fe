"""What the studies' runs cost: the time each finished run trained, per study (or leaderboard
board) and method, and what the cells still to train would take at that rate.

Run: ``.venv/bin/python bench/analysis/study_cost.py [STUDY ...]`` (default: the Box Pushing
studies), or ``--leaderboard`` for the leaderboard's boards. Prints its BENCHMARKS.md section
(``bench/run_all.sh``): per study and method, the finished runs, the minutes each trained as
mean and range, and the cells not finished with the hours they would take at the method's mean
(:func:`projected` says where a rate is lent; ``?``: no rate to project), then the totals.

A run's minutes are read from its ``wall_time`` column (training, its evaluations and
checkpoints, resumed runs included, start-up left out), with one correction: the runs shared
this 2-core machine with one or two other runs and were stopped (``SIGSTOP``) while the test
suite or a benchmark ran, which shows as one iteration lasting minutes. An iteration longer than
:data:`PAUSED` times the run's median iteration is counted as a median one. What is left is
still an upper bound on a run's CPU time (a shared core runs slower), and the range says by how
much it varies.
"""

from __future__ import annotations

import argparse
import statistics
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from maopg.experiment.studies import get_study
from maopg.experiment.studies.leaderboard import BOARDS, Board, board_runs
from maopg.experiment.studies.runs import RunData, discover_runs

BOX_PUSHING = (
    "box-pushing-6",
    "box-pushing-8",
    "box-pushing-10",
    "box-pushing-mujoco",
    "box-pushing-mujoco-rgb",
    "mac-iaicc-history",
    "acac-seeds",
)
PAUSED = 20
"""An iteration this many times the run's median iteration or longer was a paused run."""
LEADERBOARD_RUNS = Path("results/leaderboard/runs")
"""Where the leaderboard trains the cells no study runs."""


def trained_minutes(run: RunData) -> float:
    """The minutes ``run`` trained: its logged wall time, every iteration longer than
    :data:`PAUSED` medians counted as a median one."""
    wall = run.column("wall_time")
    steps = np.diff(np.concatenate([[0.0], wall[~np.isnan(wall)]]))
    if steps.size > 2:
        median = float(np.median(steps))
        steps = np.where(steps > PAUSED * median, median, steps)
    return float(steps.sum()) / 60


@dataclass(frozen=True)
class Cost:
    """One row: a study's (or board's) method, the minutes its finished runs trained, and the
    hours its ``left`` cells take where a rate is known (``mark`` says whose rate:
    :func:`projected`)."""

    name: str
    method: str
    cells: int
    minutes: tuple[float, ...]
    hours: float | None
    mark: str

    @property
    def left(self) -> int:
        """The cells not finished."""
        return self.cells - len(self.minutes)

    def cells_text(self) -> list[str]:
        """The row as the table prints it."""
        mine = self.minutes
        spent = f"{statistics.fmean(mine):.0f} ({min(mine):.0f}–{max(mine):.0f})" if mine else "—"
        hours = "?" if self.hours is None else f"{self.mark}{self.hours:.1f}"
        return [self.name, self.method, f"{len(mine)}/{self.cells}", spent, str(self.left), hours]


def projected(
    left: int, mine: Sequence[float], lent: Sequence[float], beside: Sequence[float] = ()
) -> tuple[float | None, str]:
    """The hours ``left`` cells take at the mean of the method's own finished runs, else
    (``≈``) at the mean of the same method's runs of the same task elsewhere, else (``~``) at
    the mean of the other methods' runs ``beside`` it (a rough guess: methods differ), else
    none."""
    if not left:
        return 0.0, ""
    for mark, values in (("", mine), ("≈ ", lent), ("~ ", beside)):
        if values:
            return left * statistics.fmean(values) / 60, mark
    return None, ""


def _row(
    name: str,
    method: str,
    cells: int,
    mine: list[float],
    lent: list[float],
    beside: Sequence[float] = (),
) -> Cost:
    hours, mark = projected(cells - len(mine), mine, lent, beside)
    return Cost(name, method, cells, tuple(mine), hours, mark)


def _kind(name: str) -> set[tuple[str, bool]]:
    """The study's tasks, each with whether its runs see images: what costs alike."""
    study = get_study(name)
    return {(t.task, bool({**study.overrides, **t.overrides}.get("images"))) for t in study.tasks}


def study_rows(names: Iterable[str]) -> list[Cost]:
    """One row per study and method (a method's rate is lent by the other studies given that
    run the same task from the same observations: the grid's sizes lend each other theirs)."""
    names = list(names)
    minutes: dict[tuple[str, str, str], list[float]] = {}
    for name in names:
        root = get_study(name).runs_dir()
        for run in discover_runs([root]) if root.exists() else []:
            if run.finished:
                minutes.setdefault((name, run.task, run.method), []).append(trained_minutes(run))
    out: list[Cost] = []
    for name in names:
        study = get_study(name)
        tasks = {t.task for t in study.tasks}
        for method in study.methods:
            cells = sum(len(task.seeds) for task in study.tasks)
            mine = [m for task in tasks for m in minutes.get((name, task, method), [])]
            lent = [
                m
                for (other, task, meth), values in minutes.items()
                for m in values
                if meth == method and other != name and _kind(other) == _kind(name)
            ]
            out.append(_row(name, method, cells, mine, lent))
    return out


def _board_kind(board: Board) -> tuple[str, str, object]:
    """What makes two boards' runs cost alike: the task, its settings but ``mask_options``
    (the teams of eight with and without it), and the budget."""
    study = get_study(board.study)
    task = study.task(board.task)
    settings = {k: v for k, v in task.settings.items() if k != "mask_options"}
    budget = {**study.overrides, **task.overrides}.get("total_samples")
    return board.task, repr(sorted(settings.items())), budget


def board_rows() -> list[Cost]:
    """One row per leaderboard board and method, wherever its runs live (a study's or the
    leaderboard's own folder); a method's rate is lent by its boards of the same task, team
    and budget (:func:`_board_kind`)."""
    minutes: dict[tuple[str, str], list[float]] = {}
    for board in BOARDS:
        for run in board_runs(board, LEADERBOARD_RUNS):
            if run.finished:
                minutes.setdefault((board.name, run.method), []).append(trained_minutes(run))
    out: list[Cost] = []
    for board in BOARDS:
        cells = len(get_study(board.study).task(board.task).seeds)
        for method in board.methods:
            lent = [
                m
                for other in BOARDS
                if other.name != board.name and _board_kind(other) == _board_kind(board)
                for m in minutes.get((other.name, method), [])
            ]
            beside = [
                m
                for (name, other), values in minutes.items()
                if name == board.name and other != method
                for m in values
            ]
            mine = minutes.get((board.name, method), [])
            out.append(_row(board.name, method, cells, mine, lent, beside))
    return out


def _hours(rows: Sequence[Cost]) -> tuple[float, float, int]:
    """The hours the finished runs took, the hours the cells left take where a rate is known,
    and how many cells left have none."""
    spent = sum(sum(row.minutes) for row in rows) / 60
    left = sum(row.hours for row in rows if row.hours is not None)
    unknown = sum(row.left for row in rows if row.hours is None)
    return spent, left, unknown


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("studies", nargs="*", default=list(BOX_PUSHING))
    parser.add_argument("--leaderboard", action="store_true", help="the leaderboard's boards")
    args = parser.parse_args()
    what = "study" if not args.leaderboard else "board"
    header = [
        what,
        "method",
        "finished",
        "minutes a run: mean (range)",
        "cells left",
        "hours left at the mean",
    ]
    if args.leaderboard:
        rows = board_rows()
        print(
            "### What the leaderboard's runs took (`bench/analysis/study_cost.py --leaderboard`)\n"
        )
        source = (
            "Read from the runs of each board, wherever they are committed (a study's\n"
            "`results/<study>/runs`, or `results/leaderboard/runs`): "
        )
        lent = (
            "≈: the rate of the same method on another board of the same task, team and\n"
            "budget; ~: the mean rate of the other methods on the board, a rough guess"
        )
    else:
        rows = study_rows(args.studies)
        print("### What the Box Pushing studies' runs took (`bench/analysis/study_cost.py`)\n")
        source = "Read from the runs committed under `results/<study>/runs`: "
        lent = "≈: the rate of the same method on another size of the grid"
    print(
        source + "the minutes each finished run\n"
        "trained on this 2-core machine, shared with one or two other runs (an upper bound on a\n"
        f"run's CPU time; iterations over {PAUSED} medians long, the run stopped while tests ran,\n"
        "counted as a median one), and the hours the cells left would take at each method's\n"
        f"mean ({lent}).\n"
    )
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for row in rows:
        print("| " + " | ".join(row.cells_text()) + " |")
    spent, left, unknown = _hours(rows)
    unknown_note = f", and {unknown} cells with no rate yet" if unknown else ""
    print(
        f"\nIn all: {spent:.1f} hours in the finished runs, {left:.1f} hours in the cells "
        f"left at the means{unknown_note}."
    )


if __name__ == "__main__":
    main()

"""Markdown result tables per task × method: peak performance and samples to a threshold.

Peak = the best smoothed mean episode return a seed reached (and, in its own column, the best
smoothed option-step reward: the paper's metric, a different quantity — never compare the two).
Final = the mean return over the last 10% of a seed's samples: a method that peaks and then
falls back (Mac-DQN exploring at its final ε, say) differs from one that stays there.
Samples to threshold = low-level samples until a seed's smoothed return first reached the
task's threshold (declared by its study, or given); seeds that never did are
counted in the "reached" column, not averaged.

Rows of different methods are only comparable where they learnt from the same settings, so a
peak or normalised table ends with a line per task naming each learnt setting that differs
between its rows, with every row's value (none when they all share their settings).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np

from maopg.experiment.studies.runs import (
    PAPER_METRIC,
    RETURN,
    RunData,
    Summary,
    base_method,
    differences_line,
    final,
    group_runs,
    peak,
)
from maopg.experiment.studies.runs import samples_to_threshold as _samples_to_threshold
from maopg.experiment.studies.stats import bootstrap_interval


def format_summary(summary: Summary, digits: int = 1) -> str:
    """``mean ± std`` (``—`` when no seed contributed; the bare value for one seed, whose
    "± 0" would read as no spread rather than unknown spread)."""
    if summary.count == 0:
        return "—"
    if summary.count == 1:
        return f"{summary.mean:.{digits}f}"
    return f"{summary.mean:.{digits}f} ± {summary.std:.{digits}f}"


def mean_interval(values: Sequence[float], show: Callable[[float], str]) -> str:
    """``mean [low, high]``, each written by ``show``: the percentile bootstrap 95 % interval
    of the mean over seeds (``nan`` values left out); the bare value for one seed, ``—`` for
    none."""
    kept = [v for v in values if not math.isnan(v)]
    if not kept:
        return "—"
    mean = show(float(np.mean(kept)))
    if len(kept) == 1:
        return mean
    low, high = bootstrap_interval(kept)
    return f"{mean} [{show(low)}, {show(high)}]"


def _seeds(group: Sequence[RunData]) -> str:
    """How many seeds, and how many of them are still in progress (when any are included)."""
    running = sum(not r.finished for r in group)
    return f"{len(group)} ({running} unfinished)" if running else str(len(group))


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """A Markdown table of ``rows`` under ``header``."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def selected_groups(
    runs: Iterable[RunData], methods: Sequence[str] | None
) -> list[tuple[tuple[str, str], list[RunData]]]:
    """The runs' groups (:func:`group_runs`) of ``methods`` (all: ``None``), by task and then in
    ``methods``' order."""
    groups = group_runs(r for r in runs if methods is None or r.method in methods)
    order = {m: i for i, m in enumerate(methods or ())}
    return sorted(
        groups.items(),
        key=lambda kv: (kv[0][0], order.get(base_method(kv[0][1]), 0), kv[0][1]),
    )


def differences_note(selected: Sequence[tuple[tuple[str, str], list[RunData]]]) -> str:
    """For each task of the ``selected`` rows whose groups learnt from different settings:
    ``Settings that differ between the tool_delivery rows: hidden (async 128, sync-cut 32)``."""
    lines = []
    for task in sorted({task for (task, _), _ in selected}):
        line = differences_line({label: g for (t, label), g in selected if t == task})
        if line:
            lines.append(f"Settings that differ between the {task} rows: {line}.")
    return "".join(f"\n{line}\n" for line in lines)


def peak_table(
    runs: Iterable[RunData], *, window: int = 1, methods: Sequence[str] | None = None
) -> str:
    """Per task × method: seeds, peak and final return, peak paper's metric, samples trained;
    then :func:`differences_note`."""
    rows = []
    selected = selected_groups(runs, methods)
    for (task, method), group in selected:
        returns = Summary.of([peak(r, RETURN, window) for r in group])
        last = Summary.of([final(r, RETURN) for r in group])
        paper = Summary.of(
            [
                peak(r, PAPER_METRIC, window) if PAPER_METRIC in r.metrics else math.nan
                for r in group
            ]
        )
        trained = Summary.of([float(r.samples[-1]) if r.samples.size else math.nan for r in group])
        rows.append(
            [
                task,
                method,
                _seeds(group),
                format_summary(returns),
                format_summary(last),
                format_summary(paper, 2),
                format_summary(trained, 0),
            ]
        )
    header = [
        "task",
        "method",
        "seeds",
        "peak episode return",
        "final episode return (last 10%)",
        "peak option-step reward (paper's metric)",
        "samples trained",
    ]
    return markdown_table(header, rows) + differences_note(selected)


def threshold_table(
    runs: Iterable[RunData],
    thresholds: Mapping[str, float],
    *,
    window: int = 1,
    methods: Sequence[str] | None = None,
) -> str:
    """Per task × method: low-level samples until the smoothed return reached the task's
    threshold (a task without one gets a row that says so)."""
    rows = []
    for (task, method), group in selected_groups(runs, methods):
        n = len(group)
        if task not in thresholds:
            rows.append([task, method, "—", "no threshold set", f"0/{n}"])
            continue
        reached = Summary.of(
            [_samples_to_threshold(r, thresholds[task], RETURN, window) for r in group]
        )
        rows.append(
            [
                task,
                method,
                f"{thresholds[task]:g}",
                format_summary(reached, 0),
                f"{reached.count}/{n}",
            ]
        )
    header = ["task", "method", "return threshold", "samples to threshold", "seeds reached"]
    return markdown_table(header, rows)


def normalised_table(runs: Iterable[RunData], references: Mapping[str, tuple[float, float]]) -> str:
    """Per task × method: the final return as ``(R − R_random) / (R_scripted − R_random)``.

    ``references`` maps a task to its ``(random, scripted)`` mean returns, measured at the
    study's settings: 0 is the uniform-random policy, 1 the scripted heuristic.
    """
    rows = []
    selected = [(key, g) for key, g in selected_groups(runs, None) if key[0] in references]
    for (task, method), group in selected:
        random, scripted = references[task]
        scores = [(final(r, RETURN) - random) / (scripted - random) for r in group]
        rows.append(
            [
                task,
                method,
                _seeds(group),
                format_summary(Summary.of([final(r, RETURN) for r in group])),
                format_summary(Summary.of(scores), 2),
            ]
        )
    header = ["task", "method", "seeds", "final episode return (last 10%)", "normalised score"]
    return markdown_table(header, rows) + differences_note(selected)

"""Box Pushing's evaluation during training beside the published curves: the tables and figure
of a study that declares ``published`` (:class:`~maopg.experiment.studies.registry.Study`).

The literature reads a Box Pushing curve one way (the box-pushing reference, kept beside the
repository in ``shared/reference/box_pushing_reference.md``, §8-§9): during training
the policy plays 10 episodes, sampled, every 96 training episodes (its ``Eval/Return``), and a
seed's **value at T** is the mean of its last 5 such evaluations logged at or before T steps;
a method's is the mean ± sample standard deviation (``ddof=1``) over its seeds. maopg's runs
log the same evaluation (``eval_every``: the ``eval_return`` column, ``nan`` in rows without
one) and are read here by the same rule, so the rows of :func:`value_table` stand beside the
published ones (:data:`PUBLISHED`).

The x axis is maopg's sample counter, which is stricter than the published one: maopg counts
every simulated tick of every environment, the episodes cut at a batch boundary included, where
the published ``Timesteps`` count only the ticks of the training episodes that finished (the
partial ones are thrown away). At the same T a maopg run has simulated at most as many steps as
a published one.

A mean hides what the seeds learn: on Box Pushing they split between the big box (about 300)
and the small boxes (about 20 each, 40 at most in one episode) — the published ACAC's ±116 on
bp8 and bp10 is four seeds at 299 and one at 39. :func:`outcome_table` classes each seed by its
final value (:func:`outcome`) and lists every seed's value and big-box rate.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from maopg.experiment.run.directory import EVAL_COLUMNS
from maopg.experiment.studies.plots import METHOD_COLOURS, RECURRENT_SUFFIX
from maopg.experiment.studies.runs import RunData, Summary, base_method, mean_curve
from maopg.experiment.studies.stats import RESAMPLES, bootstrap_interval, fisher_exact
from maopg.experiment.studies.tables import format_summary, markdown_table, selected_groups

EVAL_RETURN, _, EVAL_SUCCESS, _ = EVAL_COLUMNS
LAST = 5
"""Evaluations a value at T averages (reference §9)."""
PUBLISHED_SAMPLES = (50_000, 100_000, 200_000, 300_000, 500_000)
"""The steps T of the published table."""
PUBLISHED_METHODS = {
    "acac": "ACAC",
    "mac_iaicc": "Mac-IAICC",
    "mac_niacc": "Mac-NIACC",
    "mappo": "MAPPO (primitive actions)",
}
"""The published methods, by their log names, as their papers name them."""
PUBLISHED_SEEDS = 5
"""Seeds of every published row (0-4)."""
PUBLISHED_RUNS: Mapping[str, Mapping[str, tuple[tuple[float, ...], ...]]] = {
    "bp6": {
        "acac": (
            (38.85, 299.4, 299.4, 299.4, 299.4),
            (21.108, 299.3, 299.3, 299.3, 299.3),
            (38.6, 299.3, 299.3, 299.3, 299.3),
            (35.132, 299.3, 299.3, 299.3, 299.3),
            (38.072, 299.4, 299.4, 299.4, 299.4),
        ),
        "mac_iaicc": (
            (19.751, 17.138, 31.954, 289.362, 291.138),
            (22.891, 19.417, 221.715, 296.563, 288.118),
            (18.025, 23.724, 189.229, 292.205, 291.007),
            (18.16, 18.923, 20.632, 288.85, 292.47),
            (27.802, 16.32, 48.296, 285.719, 270.36),
        ),
        "mac_niacc": (
            (18.402, 20.57, 21.74, 32.349, 33.185),
            (17.476, 18.889, 234.128, 292.716, 293.722),
            (16.485, 24.128, 249.275, 298.136, 297.301),
            (17.688, 18.892, 21.575, 282.524, 296.931),
            (21.778, 15.744, 281.883, 294.041, 295.665),
        ),
        "mappo": (
            (-42.66, -11.266, -8.866, -1.738, 0.854),
            (-28.082, -5.988, -19.554, -0.178, -2.158),
            (-40.96, -13.618, -2.294, 0.912, -10.192),
            (-30.82, -2.856, -6.162, -7.496, 8.304),
            (-40.476, -0.406, -4.364, -11.474, -4.512),
        ),
    },
    "bp8": {
        "acac": (
            (23.504, 295.39, 299.2, 299.2, 299.2),
            (24.516, 297.201, 299.2, 299.2, 299.2),
            (39.15, 39.275, 39.4, 39.4, 39.4),
            (22.061, 295.547, 299.1, 299.1, 299.1),
            (34.837, 21.9, 299.1, 299.1, 299.1),
        ),
        "mac_iaicc": (
            (16.485, 26.564, 18.156, 28.31, 266.868),
            (18.161, 19.27, 19.68, 20.286, 36.65),
            (23.541, 17.379, 19.589, 233.308, 280.372),
            (22.92, 17.917, 19.688, 18.792, 18.864),
            (16.708, 31.374, 19.562, 21.027, 32.179),
        ),
        "mac_niacc": (
            (19.651, 17.116, 26.57, 182.466, 268.154),
            (12.747, 18.244, 19.062, 19.518, 29.167),
            (22.707, 18.964, 19.796, 18.747, 19.4),
            (18.056, 19.944, 19.355, 18.762, 18.037),
            (14.225, 18.732, 20.131, 20.234, 20.197),
        ),
        "mappo": (
            (-37.627, -12.6, -11.0, -10.0, -10.0),
            (-43.207, -11.4, -10.2, -10.0, -10.0),
            (-38.163, -11.0, -10.0, -10.0, -10.0),
            (-43.723, -11.6, -10.0, -10.0, -10.0),
            (-56.75, -12.2, -10.2, -10.0, -10.4),
        ),
    },
    "bp10": {
        "acac": (
            (25.483, 37.513, 298.8, 298.8, 298.8),
            (19.917, 37.575, 298.9, 298.9, 298.9),
            (34.689, 39.075, 39.2, 39.2, 39.2),
            (24.38, 37.575, 298.8, 298.8, 298.8),
            (24.777, 36.513, 298.9, 298.9, 298.9),
        ),
        "mac_iaicc": (
            (22.093, 14.973, 19.323, 18.565, 19.074),
            (21.47, 13.251, 20.289, 19.926, 32.936),
            (21.519, 21.683, 18.126, 20.155, 260.127),
            (16.027, 18.036, 18.718, 18.593, 18.841),
            (21.454, 27.294, 19.668, 20.092, 20.279),
        ),
        "mac_niacc": (
            (21.972, 16.966, 18.718, 19.56, 30.899),
            (23.816, 24.327, 18.948, 19.479, 22.602),
            (22.875, 18.845, 19.383, 18.326, 18.409),
            (16.256, 18.092, 18.42, 18.583, 18.675),
            (18.143, 22.081, 16.071, 19.081, 20.596),
        ),
        "mappo": (
            (-36.5, -12.4, -10.4, -10.0, -10.0),
            (-47.5, -11.0, -10.2, -10.4, -10.0),
            (-43.217, -11.2, -10.2, -10.0, -10.0),
            (-39.5, -13.4, -10.2, -10.0, -10.0),
            (-57.25, -13.2, -10.0, -10.0, -10.4),
        ),
    },
}
"""Published facts, not maopg's results: each published seed's (0-4, in order) value at each of
:data:`PUBLISHED_SAMPLES` on the grid of each size (``bp6``: 6x6), to 3 decimals, from the ACAC
code release's logs (LGAI-Research/acac, ``icml25_result/log``, ``Timesteps`` counted as the
box-pushing reference's §8 says) by the rule of this module; ``bench/analysis/published_seeds.py``
prints them from a mirror of that repository and checks these against it
(``docs/results/published_box_pushing.md``). mappo logs about every 10K steps, so its value at
50K on bp6 seed 2 averages the 4 evaluations logged by then."""
PUBLISHED: Mapping[str, Mapping[str, tuple[tuple[float, float], ...]]] = {
    size: {
        method: tuple(
            (statistics.fmean(at), statistics.stdev(at)) for at in zip(*seeds, strict=True)
        )
        for method, seeds in methods.items()
    }
    for size, methods in PUBLISHED_RUNS.items()
}
"""Each published method's value at each of :data:`PUBLISHED_SAMPLES` as ``(mean, sample
SD)`` over its seeds: the box-pushing reference's §9 table, to its rounding but where the
seeds' three decimals tip a last digit (bp10 ACAC at 100K: 37.650 here, 37.6 there)."""
PUBLISHED_THRESHOLDS = {"bp6": 240.0, "bp8": 200.0, "bp10": 200.0}
"""The published table's thresholds (box-pushing reference §9, "first ≥ thr")."""
PUBLISHED_FIRST: Mapping[str, Mapping[str, float]] = {
    "bp6": {"acac": 73_000, "mac_iaicc": 235_000, "mac_niacc": 294_000, "mappo": math.nan},
    "bp8": {"acac": 107_000, "mac_iaicc": math.nan, "mac_niacc": math.nan, "mappo": math.nan},
    "bp10": {"acac": 135_000, "mac_iaicc": math.nan, "mac_niacc": math.nan, "mappo": math.nan},
}
"""The published table's "first ≥ thr": the smallest T on a 1,000-step grid where the 5-seed
mean of the values at T reaches the size's threshold (:data:`PUBLISHED_THRESHOLDS`); ``nan``:
not reached by the end of the logs."""
FIRST_GRID = 1_000
"""Steps between the T at which :func:`first_at_threshold` tries the mean."""
SAMPLES = "samples"
"""maopg's counter: every simulated tick of every environment."""
PUBLISHED_COUNTER = "published_steps"
"""The metrics column of the methods whose rounds count steps as the published logs do (only
the ticks of finished training episodes: ``acac`` and MacroMARL's methods)."""
VALIDATED = {"acac": "acac", "mac-iaicc": "mac_iaicc"}
"""maopg's methods validated against a published one (its log name in :data:`PUBLISHED_RUNS`)."""
VALIDATION_SAMPLES = (100_000, 200_000, 500_000)
"""The T at which a validated method's 5-seed mean is set against the published seeds."""
MATCH_P = 0.05
"""A big-box count matches the published one while Fisher's exact test gives p above it."""
GRID_TASK = "box_pushing_grid"
"""The task the published curves were measured on (the others are read against them)."""

BIG_BOX = 200.0
"""A final value at or above it says "big box": the big box pays 300 (298.9-299.6 in the
fastest episodes), an episode without it at most 40 (both small boxes at once; a delivery ends
the episode), so a mean of 200 needs the big box in at least 62% of the evaluated episodes,
(200 − 40) / (299 − 40)."""
MOST_WITHOUT_BIG_BOX = 40.0
"""No episode without the big box pays more (both small boxes in one step): a mean above it is
the big box in some episodes."""
SMALL_BOXES = 15.0
"""A final value at or above it (and at most 40) says "small boxes only": a small box pays 20
(19.0-19.6 by the fastest route), a timeout −10 and every penalised push −10 more, so 15 needs
a quick small box in nearly every episode (a random team scores 2.7-4.7: reference §7)."""
DODGE = 4_000
"""Samples between the published methods' markers at one T, in the figure."""
OUTCOMES = ("big box", "big box at times", "small boxes only", "nothing")
"""What a seed learnt, best first (:func:`outcome`)."""


def value_at(
    run: RunData, samples: float, metric: str = EVAL_RETURN, counter: str = SAMPLES
) -> float:
    """The run's value at ``samples`` (reference §9): the mean of its last :data:`LAST`
    evaluations (``metric``) logged at ``samples`` or before on ``counter`` (maopg's
    ``samples``, or :data:`PUBLISHED_COUNTER`). ``nan`` where the run has not trained that far,
    or logged no evaluation by then."""
    if metric not in run.metrics or (counter != SAMPLES and counter not in run.metrics):
        return math.nan
    steps = run.counted(counter)
    if not steps.size or steps[-1] < samples:
        return math.nan
    values = run.column(metric)
    seen = ~np.isnan(values)
    last = values[seen][steps[seen] <= samples][-LAST:]
    return float(last.mean()) if last.size else math.nan


def final_value(run: RunData, metric: str = EVAL_RETURN) -> float:
    """The run's value at its budget (``total_samples``): the value at 500K of a 500K run."""
    return value_at(run, float(run.config["total_samples"]), metric)


def over_seeds(values: Iterable[float]) -> Summary:
    """Mean ± sample standard deviation (``ddof=1``, as the published table) of the values
    that are not ``nan``; the deviation is ``nan`` for a single value."""
    kept = np.array([v for v in values if not math.isnan(v)], dtype=np.float64)
    if kept.size == 0:
        return Summary(math.nan, math.nan, 0)
    std = float(kept.std(ddof=1)) if kept.size > 1 else math.nan
    return Summary(float(kept.mean()), std, int(kept.size))


def outcome(value: float) -> str:
    """What a seed's final value says it learnt (:data:`OUTCOMES`; ``not evaluated`` for
    ``nan``): the big box (:data:`BIG_BOX`), the big box in some episodes only (above
    :data:`MOST_WITHOUT_BIG_BOX`), small boxes only (:data:`SMALL_BOXES`) or nothing."""
    if math.isnan(value):
        return "not evaluated"
    if value >= BIG_BOX:
        return OUTCOMES[0]
    if value > MOST_WITHOUT_BIG_BOX:
        return OUTCOMES[1]
    return OUTCOMES[2] if value >= SMALL_BOXES else OUTCOMES[3]


def _thousands(samples: int) -> str:
    return f"{samples // 1000}K"


def _values(group: Sequence[RunData], samples: Sequence[int], counter: str) -> list[str]:
    """The group's value at each T of ``samples`` on ``counter``: mean ± sample SD over seeds,
    ``(n)`` after it where only n of the seeds trained that far."""
    cells = []
    for t in samples:
        summary = over_seeds(value_at(r, t, counter=counter) for r in group)
        partial = f" ({summary.count})" if 0 < summary.count < len(group) else ""
        cells.append(format_summary(summary) + partial)
    return cells


def value_table(
    runs: Iterable[RunData], published: str, samples: Sequence[int] = PUBLISHED_SAMPLES
) -> str:
    """Per task × method: the value at each T of ``samples`` (:func:`_values`), again on the
    published counter for the methods that log it, then the published rows of ``published`` (a
    key of :data:`PUBLISHED`)."""
    rows = []
    for (task, label), group in selected_groups(runs, None):
        rows.append([task, label, str(len(group)), *_values(group, samples, SAMPLES)])
        if all(PUBLISHED_COUNTER in r.metrics for r in group):
            cells = _values(group, samples, PUBLISHED_COUNTER)
            rows.append([task, f"{label}, published counter", str(len(group)), *cells])
    columns = [PUBLISHED_SAMPLES.index(t) if t in PUBLISHED_SAMPLES else None for t in samples]
    for method, values in PUBLISHED[published].items():
        cells = [
            "—" if k is None else format_summary(Summary(*values[k], PUBLISHED_SEEDS))
            for k in columns
        ]
        name = PUBLISHED_METHODS[method]
        rows.append([f"{published} (published)", name, str(PUBLISHED_SEEDS), *cells])
    header = ["task", "method", "seeds", *(_thousands(t) for t in samples)]
    return markdown_table(header, rows)


def first_at_threshold(group: Sequence[RunData], threshold: float, counter: str = SAMPLES) -> float:
    """The published table's "first ≥ thr" of a group of seeds: the smallest T on a
    :data:`FIRST_GRID`-step grid at which the mean over the seeds of their values at T
    (:func:`value_at` on ``counter``) reaches ``threshold``, over the T every seed has trained
    to; ``nan`` if never."""
    ends = []
    for run in group:
        steps = run.samples if counter == SAMPLES else run.metrics.get(counter)
        if steps is None or not steps.size:
            return math.nan
        ends.append(float(steps[-1]))
    for t in range(FIRST_GRID, int(min(ends)) + 1, FIRST_GRID):
        if statistics.fmean(value_at(r, t, counter=counter) for r in group) >= threshold:
            return float(t)
    return math.nan


def first_table(runs: Iterable[RunData], published: str) -> str:
    """Per task × method the "first ≥ thr" of its seeds (:func:`first_at_threshold`) on
    maopg's counter, again on the published counter for the methods that log it, then the
    published rows of ``published``."""
    threshold = PUBLISHED_THRESHOLDS[published]

    def said(t: float) -> str:
        return "not reached" if math.isnan(t) else _thousands(int(t))

    rows = []
    for (task, label), group in selected_groups(runs, None):
        rows.append([task, label, str(len(group)), said(first_at_threshold(group, threshold))])
        if all(PUBLISHED_COUNTER in r.metrics for r in group):
            first = first_at_threshold(group, threshold, PUBLISHED_COUNTER)
            rows.append([task, f"{label}, published counter", str(len(group)), said(first)])
    for method, first in PUBLISHED_FIRST[published].items():
        name = PUBLISHED_METHODS[method]
        rows.append([f"{published} (published)", name, str(PUBLISHED_SEEDS), said(first)])
    header = ["task", "method", "seeds", f"first T with the mean over seeds ≥ {threshold:g}"]
    return markdown_table(header, rows)


def lowest_evaluations(group: Sequence[RunData]) -> str:
    """Each seed's lowest evaluation over its whole run: a final value says where a seed
    ended, not what it went through on the way (``—``: a seed with no evaluation)."""
    cells = []
    for r in group:
        values = r.column(EVAL_RETURN) if EVAL_RETURN in r.metrics else np.array([])
        seen = values[~np.isnan(values)]
        cells.append(f"seed{r.seed} " + (f"{seen.min():.1f}" if seen.size else "—"))
    return ", ".join(cells)


def outcome_table(runs: Iterable[RunData]) -> str:
    """Per task × method: how many seeds' final values (:func:`final_value`) say each outcome,
    every seed's final value with its big-box rate (``eval_success`` over the same
    evaluations), and every seed's lowest evaluation (:func:`lowest_evaluations`)."""
    rows = []
    for (task, label), group in selected_groups(runs, None):
        values = [final_value(r) for r in group]
        said = [outcome(v) for v in values]
        seeds = ", ".join(
            f"seed{r.seed} —"
            if math.isnan(v)
            else f"seed{r.seed} {v:.1f} ({final_value(r, EVAL_SUCCESS):.0%})"
            for r, v in zip(group, values, strict=True)
        )
        unevaluated = said.count("not evaluated")
        counts = [str(said.count(o)) for o in OUTCOMES]
        note = f" ({unevaluated} not evaluated)" if unevaluated else ""
        rows.append([task, label, f"{len(group)}{note}", *counts, seeds, lowest_evaluations(group)])
    header = [
        "task",
        "method",
        "seeds",
        *OUTCOMES,
        "each seed: final value (big-box rate)",
        "each seed: lowest evaluation",
    ]
    return markdown_table(header, rows)


def validation_table(runs: Iterable[RunData], published: str) -> str:
    """Each validated method (:data:`VALIDATED`) on the grid against its published seeds of
    ``published``: at each T of :data:`VALIDATION_SAMPLES`, on the published counter, maopg's
    mean over its seeds beside the published seeds' mean and the bootstrap 95 % interval of
    that mean (:func:`~maopg.experiment.studies.stats.bootstrap_interval`; it matches when
    maopg's mean lies inside); then how many seeds deliver the big box at the last T (value
    ≥ :data:`BIG_BOX`) on either side, and Fisher's exact test of the two counts (it matches
    while p > :data:`MATCH_P`), and the value of the seeds that deliver it
    (:func:`_big_box_seeds_row`). A verdict is given once as many seeds as the published
    (:data:`PUBLISHED_SEEDS`) have trained that far, ``—`` before. Empty where no validated
    method has runs."""
    rows = []
    last = VALIDATION_SAMPLES[-1]
    for (task, label), group in selected_groups(runs, None):
        name = VALIDATED.get(base_method(label))
        if task != GRID_TASK or name is None:
            continue
        seeds = PUBLISHED_RUNS[published][name]
        for t in VALIDATION_SAMPLES:
            theirs = [values[PUBLISHED_SAMPLES.index(t)] for values in seeds]
            ours = over_seeds(value_at(r, t, counter=PUBLISHED_COUNTER) for r in group)
            low, high = bootstrap_interval(theirs)
            verdict = "—" if ours.count < PUBLISHED_SEEDS else _yes(low <= ours.mean <= high)
            rows.append(
                [
                    label,
                    _thousands(t),
                    f"{ours.mean:.2f} ({ours.count} of {len(group)})" if ours.count else "—",
                    f"{statistics.fmean(theirs):.2f}",
                    f"[{low:.2f}, {high:.2f}]",
                    verdict,
                ]
            )
        finals = [value_at(r, last, counter=PUBLISHED_COUNTER) for r in group]
        ours_big = sum(v >= BIG_BOX for v in finals)
        theirs_big = sum(values[PUBLISHED_SAMPLES.index(last)] >= BIG_BOX for values in seeds)
        evaluated = sum(not math.isnan(v) for v in finals)
        p = fisher_exact(ours_big, evaluated, theirs_big, len(seeds)) if evaluated else math.nan
        verdict = "—" if evaluated < PUBLISHED_SEEDS else _yes(p > MATCH_P)
        rows.append(
            [
                label,
                f"big box at {_thousands(last)}",
                f"{ours_big} of {evaluated}",
                f"{theirs_big} of {len(seeds)}",
                f"Fisher exact p = {p:.2f}" if evaluated else "—",
                verdict,
            ]
        )
        rows.append(_big_box_seeds_row(label, finals, seeds, evaluated < PUBLISHED_SEEDS))
    header = [
        "method",
        "T (published counter)",
        "maopg",
        f"published {published}",
        "published: bootstrap 95 % of the mean",
        "matches",
    ]
    return markdown_table(header, rows) if rows else ""


def _big_box_seeds_row(
    label: str,
    finals: Sequence[float],
    seeds: Sequence[Sequence[float]],
    unfinished: bool,
) -> list[str]:
    """The value at the last T of :data:`VALIDATION_SAMPLES` over the seeds that deliver the big
    box alone, on either side, against the bootstrap interval of the published ones' mean.

    A mean over seeds mixes two outcomes, about 299 and about 39: the published bp8 and bp10
    ACAC have four seeds at the big box and one at the small boxes, so the bootstrap interval of
    their mean ends below their best seed, and five seeds that all deliver fall above it however
    well each one does. This row separates the two questions: the count is Fisher's, and here a
    seed that delivers is set against the published seeds that deliver."""
    last = VALIDATION_SAMPLES[-1]
    ours = [v for v in finals if v >= BIG_BOX]
    theirs = [v[PUBLISHED_SAMPLES.index(last)] for v in seeds]
    theirs = [v for v in theirs if v >= BIG_BOX]
    if not ours or not theirs:
        return [label, f"big-box seeds at {_thousands(last)}", "—", "—", "—", "—"]
    low, high = bootstrap_interval(theirs)
    return [
        label,
        f"big-box seeds at {_thousands(last)}",
        f"{statistics.fmean(ours):.2f} ({len(ours)})",
        f"{statistics.fmean(theirs):.2f} ({len(theirs)})",
        f"[{low:.2f}, {high:.2f}]",
        "—" if unfinished else _yes(low <= statistics.fmean(ours) <= high),
    ]


def _yes(holds: bool) -> str:
    return "yes" if holds else "no"


def _evaluation_settings(runs: Sequence[RunData]) -> str:
    """How the runs evaluated during training, read from their configs."""

    def said(key: str, words: Mapping[object, str] | None = None) -> str:
        values = {r.config.get(key) for r in runs}
        return " or ".join(sorted(str((words or {}).get(v, v)) for v in values))

    choice = said("eval_during_sample", {True: "sampled", False: "greedy"})
    return (
        f"every {said('eval_every')} samples, {said('eval_during_episodes')} episodes, "
        f"options {choice}"
    )


def published_sections(runs: Sequence[RunData], published: str) -> list[tuple[str, str]]:
    """The ``tables.md`` sections of a study that compares with ``published``: the value at
    each published T beside the published values, and what each seed learnt."""
    how = _evaluation_settings(runs) if runs else "no runs yet"
    intro = (
        "Each run evaluates its policy during training (here: "
        f"{how}); a seed's value at T is the mean of its last {LAST} evaluations "
        "(`eval_return`) at or before T samples, and a row is the mean ± sample SD (ddof 1) "
        f"over its seeds, as the published table reads the ACAC logs (box-pushing reference "
        f"§9). The published rows are that table's {published}, computed from the authors' "
        "values of each seed (their logs, to 3 decimals, by the same rule): published facts, "
        "not maopg's results; from those decimals a last digit can differ by one from the "
        "reference's table.\n\n"
        "T is on maopg's counter: every simulated tick of every environment, episodes cut at "
        "a batch boundary included. The published counter counts only the ticks of finished "
        "training episodes (reference §8), so at the same T a maopg run has simulated at most "
        "as many steps: the comparison is stricter on maopg's side.\n"
    )
    others = sorted({r.task for r in runs} - {GRID_TASK})
    if others:
        intro += (
            f"\nThe published curves were measured on {GRID_TASK}; {', '.join(others)} "
            "shares its layout and rewards but not its dynamics: the published rows are a "
            "level to read against, not the same experiment.\n"
        )
    outcomes = (
        f"A seed's final value is its value at its budget. Big box: ≥ {BIG_BOX:g} (an episode "
        f"without the big box pays at most {MOST_WITHOUT_BIG_BOX:g}, so this needs the big box "
        "in most episodes); big box at times: above "
        f"{MOST_WITHOUT_BIG_BOX:g}; small boxes only: ≥ {SMALL_BOXES:g} (a quick small box in "
        "nearly every episode; a random team scores 3-5); nothing: below. The big-box rate is "
        f"the share of the same {LAST} evaluations' episodes that delivered the big box. The "
        "lowest evaluation is the lowest a seed logged over its whole run: a team that "
        "pushes into a wall or the big box alone every tick pays −10 a push, down to about "
        "−2,000 an episode, where one that does nothing scores −10.\n\n"
    )
    sections = [
        (
            f"Evaluation during training beside the published {published} curves",
            intro + "\n" + value_table(runs, published),
        ),
        ("What each seed learns", outcomes + outcome_table(runs)),
        (
            "First T where the mean over seeds reaches the published threshold",
            'The published table\'s "first ≥ thr" (box-pushing reference §9): the smallest T '
            f"on a {FIRST_GRID:,}-step grid at which the mean over a method's seeds of their "
            "values at T reaches the threshold of the size "
            f"({PUBLISHED_THRESHOLDS[published]:g} for {published}), over the T every seed has "
            "trained to. A row over fewer seeds than the published 5 is not yet comparable. "
            "It reads the same evaluations as the values above; the samples-to-threshold "
            "table further down reads the training episodes, which explore.\n\n"
            + first_table(runs, published),
        ),
    ]
    validation = validation_table(runs, published)
    if validation:
        how = (
            "The methods that reproduce a published one, read on the published counter "
            f"(`{PUBLISHED_COUNTER}`: the ticks of finished training episodes, as the published "
            "logs count them). A value at T matches when maopg's mean over its seeds lies in "
            "the bootstrap 95 % interval of the mean of the published seeds' values "
            f"({RESAMPLES:,} resamples); the big-box counts match while Fisher's exact test "
            f"gives p > {MATCH_P:g}. The big-box seeds' row sets maopg's seeds that deliver "
            "the big box against the published seeds that do: a mean over seeds mixes about "
            "299 with about 39, and where the published seeds include one at the small boxes "
            "the interval of their mean ends below their best seed. `—`: fewer than the published "
            f"{PUBLISHED_SEEDS} seeds have trained that far yet. Mac-IAICC's "
            "published settings and step counter are not published with its logs: its rows "
            "are its MacroMARL settings, read on the same counter as ACAC's.\n\n"
        )
        sections.append((f"Validation against the published {published} runs", how + validation))
    return sections


def plot_published(runs: Sequence[RunData], out_stem: str | Path, published: str) -> list[Path]:
    """One task's evaluation curves beside the published values: per method the mean over
    seeds of each seed's value at T (the trailing mean of its last :data:`LAST` evaluations,
    drawn at every evaluation), each seed's own line faint, and the published methods' value
    ± SD at :data:`PUBLISHED_SAMPLES` as markers (their per-row curves are not published), each
    method's a little to the side of T (:data:`DODGE`) so that their error bars stay apart.
    A method whose runs log the published counter (ACAC's and MacroMARL's rounds) is drawn on
    it, the axis its published values are read on; the axis ends at the last published T.
    Writes ``<out_stem>.png`` and ``.svg``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5))
    for (_, label), group in selected_groups(runs, None):
        family = base_method(label).removesuffix(RECURRENT_SUFFIX)
        colour = METHOD_COLOURS.get(family)
        style = "--" if family != base_method(label) else "-"
        evaluated = [r for r in group if EVAL_RETURN in r.metrics]
        if evaluated and all(PUBLISHED_COUNTER in r.metrics for r in evaluated):
            evaluated = [replace(r, samples=r.column(PUBLISHED_COUNTER)) for r in evaluated]
            label = f"{label}, published counter"
        for run in evaluated:
            ax.plot(*run.curve(EVAL_RETURN, LAST), color=colour, ls=style, lw=0.7, alpha=0.3)
        at, mean, _ = mean_curve(evaluated, EVAL_RETURN, LAST)
        if at.size:
            seeds = f"{len(group)} seed" + ("s" if len(group) > 1 else "")
            ax.plot(at, mean, color=colour, ls=style, lw=2, label=f"{label} ({seeds})")
    methods = PUBLISHED[published]
    for k, ((method, values), marker) in enumerate(zip(methods.items(), "os^x", strict=True)):
        means, sds = zip(*values, strict=True)
        shift = DODGE * (k - (len(methods) - 1) / 2)
        ax.errorbar(
            [t + shift for t in PUBLISHED_SAMPLES],
            means,
            yerr=sds,
            fmt=marker,
            color="0.2",
            capsize=3,
            ms=5,
            label=f"{PUBLISHED_METHODS[method]}, published {published}",
        )
    ax.set_xlabel(
        "low-level steps: maopg's counter (every tick: stricter than the published),\n"
        "or the published counter (finished training episodes' ticks) where a run logs it"
    )
    ax.set_xlim(0, PUBLISHED_SAMPLES[-1] * 1.04)
    ax.set_ylabel(f"evaluation return, mean of the last {LAST} evaluations")
    tasks = ", ".join(sorted({r.task for r in runs}))
    title = f"{tasks}: evaluation during training\nbeside the published {published} values ± SD"
    ax.set_title(title, fontsize=11)
    ax.grid(alpha=0.3)
    ax.xaxis.set_major_formatter(lambda x, _: _thousands(int(x)))
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=7)
    fig.tight_layout()
    out_stem = Path(out_stem)
    out_stem.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    # Fixed SVG ids and no dates: the same runs redraw byte-identical files.
    with plt.rc_context({"svg.hashsalt": "maopg"}):
        for suffix, metadata in ((".png", {"Software": None}), (".svg", {"Date": None})):
            paths.append(out_stem.with_suffix(suffix))
            fig.savefig(paths[-1], dpi=130, metadata=metadata)
    plt.close(fig)
    return paths

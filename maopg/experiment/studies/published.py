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
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from maopg.experiment.run.directory import EVAL_COLUMNS
from maopg.experiment.studies.plots import METHOD_COLOURS, RECURRENT_SUFFIX
from maopg.experiment.studies.runs import RunData, Summary, base_method, mean_curve
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
PUBLISHED: Mapping[str, Mapping[str, tuple[tuple[float, float], ...]]] = {
    "bp6": {
        "acac": ((34.4, 7.6), (299.3, 0.1), (299.3, 0.1), (299.3, 0.1), (299.3, 0.1)),
        "mac_iaicc": ((21.3, 4.1), (19.1, 2.9), (102.4, 95.3), (290.5, 4.1), (286.6, 9.2)),
        "mac_niacc": ((18.4, 2.0), (19.6, 3.1), (161.7, 129.0), (240.0, 116.2), (243.4, 117.5)),
        "mappo": ((-36.6, 6.6), (-6.8, 5.6), (-8.2, 6.8), (-4.0, 5.3), (-1.5, 6.8)),
    },
    "bp8": {
        "acac": ((28.8, 7.7), (189.9, 145.5), (247.2, 116.2), (247.2, 116.2), (247.2, 116.2)),
        "mac_iaicc": ((19.6, 3.4), (22.5, 6.2), (19.3, 0.7), (64.3, 94.5), (127.0, 134.1)),
        "mac_niacc": ((17.5, 4.0), (18.6, 1.0), (21.0, 3.1), (51.9, 73.0), (71.0, 110.3)),
        "mappo": ((-43.9, 7.7), (-11.8, 0.6), (-10.3, 0.4), (-10.0, 0.0), (-10.1, 0.2)),
    },
    "bp10": {
        "acac": ((25.8, 5.4), (37.6, 0.9), (246.9, 116.1), (246.9, 116.1), (246.9, 116.1)),
        "mac_iaicc": ((20.5, 2.5), (19.0, 5.6), (19.2, 0.8), (19.5, 0.8), (70.3, 106.3)),
        "mac_niacc": ((20.6, 3.3), (20.1, 3.1), (18.3, 1.3), (19.0, 0.5), (22.2, 5.1)),
        "mappo": ((-44.8, 8.1), (-12.2, 1.1), (-10.2, 0.1), (-10.1, 0.2), (-10.1, 0.2)),
    },
}
"""Published facts, not maopg's results: each method's value at each of
:data:`PUBLISHED_SAMPLES` as ``(mean, sample SD)`` over seeds 0-4, on the grid of each size
(``bp6``: 6x6). Source: the box-pushing reference (``shared/reference/box_pushing_reference.md``,
§9 "Published curves"), computed there from the ACAC code release's logs (LGAI-Research/acac,
``icml25_result/log``) by the rule of this module. Those logs count ``Timesteps`` as §8 says."""
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


def value_at(run: RunData, samples: float, metric: str = EVAL_RETURN) -> float:
    """The run's value at ``samples`` (reference §9): the mean of its last :data:`LAST`
    evaluations (``metric``) logged at ``samples`` or before. ``nan`` where the run has not
    trained that far, or logged no evaluation by then."""
    if metric not in run.metrics or not run.samples.size or run.samples[-1] < samples:
        return math.nan
    at, values = run.curve(metric)
    last = values[at <= samples][-LAST:]
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


def value_table(
    runs: Iterable[RunData], published: str, samples: Sequence[int] = PUBLISHED_SAMPLES
) -> str:
    """Per task × method: the value at each T of ``samples`` (mean ± sample SD over seeds;
    ``(n)`` after it where only n of the seeds trained that far), then the published rows of
    ``published`` (a key of :data:`PUBLISHED`)."""
    rows = []
    for (task, label), group in selected_groups(runs, None):
        cells = []
        for t in samples:
            summary = over_seeds(value_at(r, t) for r in group)
            partial = f" ({summary.count})" if 0 < summary.count < len(group) else ""
            cells.append(format_summary(summary) + partial)
        rows.append([task, label, str(len(group)), *cells])
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


def outcome_table(runs: Iterable[RunData]) -> str:
    """Per task × method: how many seeds' final values (:func:`final_value`) say each outcome,
    and every seed's final value with its big-box rate (``eval_success`` over the same
    evaluations)."""
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
        rows.append([task, label, f"{len(group)}{note}", *counts, seeds])
    header = ["task", "method", "seeds", *OUTCOMES, "each seed: final value (big-box rate)"]
    return markdown_table(header, rows)


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
        f"§9). The published rows are that table's {published}: published facts, typed in, not "
        "maopg's results.\n\n"
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
        f"the share of the same {LAST} evaluations' episodes that delivered the big box.\n\n"
    )
    return [
        (
            f"Evaluation during training beside the published {published} curves",
            intro + "\n" + value_table(runs, published),
        ),
        ("What each seed learns", outcomes + outcome_table(runs)),
    ]


def plot_published(runs: Sequence[RunData], out_stem: str | Path, published: str) -> list[Path]:
    """One task's evaluation curves beside the published values: per method the mean over
    seeds of each seed's value at T (the trailing mean of its last :data:`LAST` evaluations,
    drawn at every evaluation), each seed's own line faint, and the published methods' value
    ± SD at :data:`PUBLISHED_SAMPLES` as markers (their per-row curves are not published), each
    method's a little to the side of T (:data:`DODGE`) so that their error bars stay apart.
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
        for run in evaluated:
            ax.plot(*run.curve(EVAL_RETURN, LAST), color=colour, ls=style, lw=0.7, alpha=0.3)
        at, mean, _ = mean_curve(evaluated, EVAL_RETURN, LAST)
        if at.size:
            ax.plot(at, mean, color=colour, ls=style, lw=2, label=f"{label} ({len(group)} seeds)")
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
    ax.set_xlabel("low-level steps, maopg's counter (every tick: stricter than the published)")
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

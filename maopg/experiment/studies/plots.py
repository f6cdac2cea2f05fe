"""Learning curves from run directories: one figure per task, one line per method, mean ± std
band over seeds, x = low-level samples (the paper's Fig. 4 axes), saved as PNG and SVG.

Each method keeps its colour in every figure, so curves can be compared across tasks. Lines
of different methods compare like with like only where they learnt from the same settings, so a
caption under the axes names each learnt setting that differs between them (none when all
share their settings).
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from maopg.experiment.studies.runs import (
    PAPER_METRIC,
    RETURN,
    RunData,
    base_method,
    differences_line,
    group_runs,
    mean_curve,
)

METHOD_COLOURS = {
    "async": "tab:red",
    "sync-cut": "tab:blue",
    "sync-wait": "tab:green",
    "end2end": "tab:purple",
    "mac-dqn": "tab:orange",
    "partial": "tab:brown",
    "acac": "tab:cyan",
    "mac-iaicc": "tab:olive",
    "mac-iac": "tab:pink",
    "naive-mac-iacc": "tab:gray",
}
LINE_STYLES = ("-", "--", ":", "-.")
"""Dash patterns of a method's settings groups, in order."""
RECURRENT_SUFFIX = "-rnn"
"""A recurrent preset (``async-rnn``) is drawn dashed in its feed-forward method's colour, so
the recurrent benchmark reads against the grid it sits beside."""
CAPTION_WIDTH = 120
"""Characters per line of the caption (7 pt text across the 7 in wide figure)."""
CAPTION_LINE = 0.028
"""Figure height (fraction) one caption line takes."""
METRIC_LABELS = {
    RETURN: "mean episode return",
    PAPER_METRIC: "mean option-step reward (paper's metric)",
}


def ordered_labels(labels: Iterable[str], methods: Sequence[str] | None) -> list[str]:
    """Group labels in ``methods``' order (each method's variants together), else by name."""
    rank = {m: i for i, m in enumerate(methods or ())}
    return sorted(labels, key=lambda label: (rank.get(base_method(label), 0), label))


def plot_task(
    runs: Sequence[RunData],
    out_stem: str | Path,
    *,
    metric: str = RETURN,
    window: int = 5,
    methods: Sequence[str] | None = None,
    title: str | None = None,
    references: Mapping[str, float] | None = None,
) -> list[Path]:
    """Plot every method of one task's ``runs``; write ``<out_stem>.png`` and ``.svg``.

    ``references`` (name → return, e.g. the scripted and random policies) are drawn as
    horizontal dashed lines, the levels a curve is read against. A method with several
    settings groups draws one line per group, in its colour with another dash pattern; the
    settings that differ between the drawn groups are named in a caption."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = {r.task for r in runs}
    if len(tasks) != 1:
        raise ValueError(f"plot_task needs the runs of exactly one task, got {sorted(tasks)}")
    task = tasks.pop()
    groups = group_runs(r for r in runs if methods is None or r.method in methods)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    variants: dict[str, int] = {}
    drawn_groups: dict[str, list[RunData]] = {}
    for label in ordered_labels((name for _, name in groups), methods):
        group = groups[(task, label)]
        x, mean, std = mean_curve(group, metric, window)
        if x.size == 0:
            continue
        drawn_groups[label] = group
        method = base_method(label)
        family = method.removesuffix(RECURRENT_SUFFIX)
        colour = METHOD_COLOURS.get(family)
        drawn = variants.get(family, 0) + (family != method)  # recurrent: dashed at least
        style = LINE_STYLES[drawn % len(LINE_STYLES)]
        variants[family] = drawn + 1
        seeds = f"{len(group)} seed{'s' if len(group) > 1 else ''}"
        marker = "o" if len(x) == 1 else None  # a single point draws no line: show it
        ax.plot(x, mean, color=colour, ls=style, marker=marker, label=f"{label} ({seeds})", lw=2)
        ax.fill_between(x, mean - std, mean + std, color=colour, alpha=0.2, lw=0)
    if metric == RETURN:
        for k, (name, level) in enumerate((references or {}).items()):
            ax.axhline(
                level, color="0.35", ls=(0, (4, 2 + 2 * k)), lw=1, label=f"{name} ({level:,.0f})"
            )
    ax.set_xlabel("low-level samples (ticks)")
    ax.set_ylabel(METRIC_LABELS.get(metric, metric))
    ax.set_title(
        title or f"{task}\nmean ± std over seeds (moving mean of {window} iterations)",
        fontsize=11,
    )
    ax.grid(alpha=0.3)
    ax.ticklabel_format(axis="x", style="sci", scilimits=(0, 3))
    if ax.lines:
        ax.legend(loc="best", fontsize=8)
    differences = differences_line(drawn_groups)
    bottom = 0.0
    if differences:
        caption = textwrap.wrap(f"Settings that differ: {differences}.", CAPTION_WIDTH)
        fig.text(0.01, 0.01, "\n".join(caption), fontsize=7, ha="left", va="bottom")
        bottom = CAPTION_LINE * len(caption) + 0.01
    fig.tight_layout(rect=(0, bottom, 1, 1))
    out_stem = Path(out_stem)
    out_stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [out_stem.with_suffix(".png"), out_stem.with_suffix(".svg")]
    # No date and fixed SVG ids: the same runs redraw byte-identical files (no noise in git).
    with plt.rc_context({"svg.hashsalt": "maopg"}):
        fig.savefig(paths[0], dpi=130, metadata={"Software": None})
        fig.savefig(paths[1], dpi=130, metadata={"Date": None})
    plt.close(fig)
    return paths


def plot_all(
    runs: Iterable[RunData],
    out_dir: str | Path,
    *,
    metric: str = RETURN,
    window: int = 5,
    methods: Sequence[str] | None = None,
    prefix: str = "curves",
    references: Mapping[str, Mapping[str, float]] | None = None,
) -> list[Path]:
    """One figure per task found in ``runs``: ``<out_dir>/<prefix>_<task>.png|svg``
    (``references``: task → its reference levels, :func:`plot_task`'s)."""
    runs = list(runs)
    paths: list[Path] = []
    for task in sorted({r.task for r in runs}):
        task_runs = [r for r in runs if r.task == task]
        paths += plot_task(
            task_runs,
            Path(out_dir) / f"{prefix}_{task}",
            metric=metric,
            window=window,
            methods=methods,
            references=(references or {}).get(task),
        )
    return paths


def curve_table(runs: Sequence[RunData], metric: str = RETURN, window: int = 5) -> str:
    """The plotted mean ± std curves of one task as CSV (``method,samples,mean,std,seeds``):
    small enough to commit, and enough to redraw a figure without the run directories."""
    lines = ["method,samples,mean,std,seeds"]
    for (_, method), group in group_runs(runs).items():
        x, mean, std = mean_curve(group, metric, window, points=100)
        lines += [
            f"{method},{s:.0f},{m:.4f},{d:.4f},{len(group)}"
            for s, m, d in zip(x, mean, std, strict=True)
        ]
    return "\n".join(lines) + "\n"


__all__ = ["METHOD_COLOURS", "curve_table", "plot_all", "plot_task"]

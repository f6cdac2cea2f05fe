"""The files of a run directory, and its per-iteration record: ``metrics.csv``, TensorBoard
scalars, the learning-curve PNG and the ``done.json`` marker.

The CSV is the record the evaluation tools and the resume test read, so floats are written with
``repr`` (exact round trip) and a resumed run first cuts the file back to the checkpoint's
sample count: rows a killed run wrote after its last checkpoint are recomputed, not duplicated.
TensorBoard is cut at the same sample count (its step), so both records keep every row up to the
checkpoint and nothing after it.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from maopg.experiment.run.wandb_log import WandbMirror

CONFIG = "config.json"
METRICS = "metrics.csv"
TENSORBOARD = "tb"
CHECKPOINT = "checkpoint.pt"
"""Everything needed to resume, written every ``checkpoint_every`` iterations (large)."""
FINAL = "final.pt"
"""The trained weights (what :func:`maopg.experiment.evaluation.loading.load_trained` reads)."""
CURVE = "learning_curve.png"
VIDEO = "rollout.mp4"
DONE = "done.json"
"""Written last, when every other output of a finished run exists: the one sign that a run is
complete. A small file of its own (not ``final.pt``) so that a results folder can keep the
record of a run — config, metrics, marker — without its weights."""

TIMING_COLUMNS = ("samples_per_s", "wall_time")
"""Columns that depend on the machine, not on the seed (excluded from determinism checks)."""
EVAL_COLUMNS = ("eval_return", "eval_return_std", "eval_success", "eval_length")
"""The columns of the evaluation during training (``eval_every``): the mean and standard
deviation of its episodes' returns, their success rate and mean length (ticks). Only a run
with ``eval_every`` > 0 writes them, ``nan`` in the rows without an evaluation
(:mod:`maopg.experiment.evaluation.evaluate`)."""


def _format(value: Any) -> str:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    return str(value)


def scalar_tag(column: str) -> str:
    """A ``metrics.csv`` column's TensorBoard (and W&B) tag: ``train/<column>``, but
    ``eval/<name>`` for the evaluation's ``eval_<name>`` (:data:`EVAL_COLUMNS`), beside the
    final evaluation's ``eval/return_greedy``."""
    if column in EVAL_COLUMNS:
        return f"eval/{column.removeprefix('eval_')}"
    return f"train/{column}"


class RunLog:
    """Appends one row per iteration to ``metrics.csv`` and mirrors it to TensorBoard.

    ``columns`` are the method's (:attr:`maopg.experiment.run.methods.Method.columns`), then the
    evaluation's (:data:`EVAL_COLUMNS`) where the run has them: the first two, iteration and
    samples, index the rows; the rest become TensorBoard scalars over samples
    (:func:`scalar_tag`). ``resume_samples`` is the sample count of the checkpoint a resumed run
    continues from: rows after it (a killed run's last ones) are dropped from both records, and
    a column the earlier rows lack (the evaluation's, switched on at the resume) is ``nan`` in
    them. Without it the run starts from its beginning, and no row or event of an earlier
    attempt survives. With ``mirror`` (``logger=wandb``) the scalars go to W&B too, which keeps
    its own rule for resumed runs (:mod:`maopg.experiment.run.wandb_log`).
    """

    def __init__(
        self,
        run_dir: Path,
        columns: tuple[str, ...],
        resume_samples: int | None = None,
        mirror: WandbMirror | None = None,
    ) -> None:
        from torch.utils.tensorboard import SummaryWriter

        self.columns = columns
        self.mirror = mirror
        self.path = run_dir / METRICS
        if resume_samples is None or not self.path.exists():
            self.path.write_text(",".join(columns) + "\n")
        else:
            kept = [
                r
                for r in read_metrics(self.path)
                if None not in r.values() and int(r["samples"]) <= resume_samples
            ]
            with self.path.open("w", newline="") as handle:
                writer = csv.DictWriter(handle, fieldnames=columns, restval="nan")
                writer.writeheader()
                writer.writerows(kept)
        if resume_samples is None:
            shutil.rmtree(run_dir / TENSORBOARD, ignore_errors=True)
        # TensorBoard hides every event of the earlier files at a step >= purge_step.
        purge = None if resume_samples is None else resume_samples + 1
        self.tb = SummaryWriter(str(run_dir / TENSORBOARD), purge_step=purge)

    def write(self, row: dict[str, Any]) -> None:
        with self.path.open("a", newline="") as handle:
            handle.write(",".join(_format(row[c]) for c in self.columns) + "\n")
        values = {scalar_tag(key): float(row[key]) for key in self.columns[2:]}
        self.scalars("", {k: v for k, v in values.items() if not math.isnan(v)}, row["samples"])

    def scalars(self, prefix: str, values: dict[str, float], step: int) -> None:
        """Scalars ``prefix/key`` in TensorBoard (and W&B) only: their keys vary by task, so they
        have no CSV column."""
        tags = {f"{prefix}/{key}" if prefix else key: value for key, value in values.items()}
        for tag, value in tags.items():
            self.tb.add_scalar(tag, value, int(step))
        if self.mirror is not None:
            self.mirror.log(int(step), tags)

    def hparams(self, config: dict[str, Any], metrics: Sequence[str]) -> None:
        """The run's settings in TensorBoard's HPARAMS tab, paired with the ``metrics`` tags it
        logs later (a new run only: a resumed one keeps the record of its first start)."""
        from torch.utils.tensorboard.summary import hparams

        plain = {
            k: v if isinstance(v, bool | int | float | str) else json.dumps(v)
            for k, v in config.items()
            if v is not None
        }
        writer = self.tb.file_writer
        for summary in hparams(plain, dict.fromkeys(metrics, math.nan)):
            writer.add_summary(summary)

    def flush(self) -> None:
        """Put the buffered TensorBoard events on disk. Before each checkpoint: a kill after it
        must not lose the rows the checkpoint covers, which a resume does not log again."""
        self.tb.flush()
        if self.mirror is not None:
            self.mirror.flush()

    def close(self) -> None:
        self.tb.close()


FINAL_FRACTION = 0.1
"""The share of a run's samples its final figure averages (:func:`final_return`, and the
studies' ``final``): the "final 10%" of the tables and of the issues' targets."""


def final_return(path: Path, fraction: float = FINAL_FRACTION) -> float | None:
    """Mean per-iteration ``episode_return`` of a ``metrics.csv`` over the last ``fraction`` of
    its samples (the rows that report one): where training ended. ``None`` when no episode
    ended there."""
    rows = read_metrics(path)
    if not rows:
        return None
    last = int(rows[-1]["samples"])
    tail = [float(r["episode_return"]) for r in rows if int(r["samples"]) > last * (1 - fraction)]
    tail = [value for value in tail if not math.isnan(value)]
    return sum(tail) / len(tail) if tail else None


def write_done(
    run_dir: Path,
    *,
    iterations: int,
    samples: int,
    wall_time: float,
    evaluation: dict[str, dict[str, float]] | None = None,
) -> Path:
    """Mark ``run_dir`` finished (atomically: a reader never sees half a marker). Besides the
    counts it records the run's ``final_return`` (:func:`final_return`) and, where the final
    policy was evaluated, ``evaluation``: per way of acting (``greedy``, ``sampled``) its
    ``episodes``, ``return_mean`` and ``success_rate``."""
    path = run_dir / DONE
    tmp = path.with_name(f".{DONE}.tmp")
    record: dict[str, Any] = {
        "iterations": iterations,
        "samples": samples,
        "wall_time": wall_time,
        "final_return": final_return(run_dir / METRICS),
    }
    if evaluation:
        record["evaluation"] = evaluation
    tmp.write_text(json.dumps(record, indent=2) + "\n")
    os.replace(tmp, path)
    return path


def read_done(run_dir: Path) -> dict[str, Any] | None:
    """The ``done.json`` record of a finished run, ``None`` while it is not finished."""
    path = run_dir / DONE
    return json.loads(path.read_text()) if path.exists() else None


def read_metrics(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def read_columns(path: Path) -> tuple[str, ...]:
    """The header of a ``metrics.csv`` (empty if the file is missing or empty)."""
    if not path.exists():
        return ()
    with path.open(newline="") as handle:
        return tuple(next(csv.reader(handle), ()))


def plot_learning_curve(csv_path: Path, png_path: Path, title: str = "") -> Path:
    """Mean episode return (per iteration and smoothed, and the evaluation's where the run
    evaluated during training) and the paper's metric vs samples."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    rows = read_metrics(csv_path)
    samples = np.array([float(r["samples"]) for r in rows])
    returns = np.array([float(r["episode_return"]) for r in rows])
    paper = np.array([float(r["option_step_reward"]) for r in rows])
    evaluated = np.array([float(r.get(EVAL_COLUMNS[0], "nan")) for r in rows])

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    seen = ~np.isnan(returns)
    top.plot(samples[seen], returns[seen], ".", alpha=0.3, label="per iteration")
    if seen.sum() >= 2:
        window = max(1, int(seen.sum()) // 20)
        kernel = np.ones(window) / window
        top.plot(
            samples[seen][window - 1 :],
            np.convolve(returns[seen], kernel, mode="valid"),
            label=f"moving mean ({window} iterations)",
        )
    shown = ~np.isnan(evaluated)
    if shown.any():  # the evaluation during training (eval_every)
        top.plot(samples[shown], evaluated[shown], "o-", ms=3, label="evaluation")
    top.set_ylabel("mean episode return")
    top.legend(loc="lower right")
    top.grid(alpha=0.3)
    bottom.plot(samples, paper, color="tab:green")
    bottom.set_ylabel("mean option-step reward\n(paper's metric)")
    bottom.set_xlabel("low-level samples (ticks)")
    bottom.grid(alpha=0.3)
    fig.suptitle(title or csv_path.parent.name)
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)
    return png_path

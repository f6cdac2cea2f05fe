"""Reading training run directories and turning their curves into per-method statistics.

A run directory (written by ``python -m train``) holds ``config.json`` (task, method, seed, ...)
and ``metrics.csv`` (one row per iteration: ``samples`` — low-level ticks so far —,
``episode_return`` — mean return of the episodes that ended in the iteration, ``nan`` if none —
and ``option_step_reward``, the paper's metric). ``done.json`` appears when the run finished.

Runs are grouped by task, method *and* the settings that change what is learnt (a run with
``env.max_ticks=100`` or a recurrent Mac-DQN is not a seed of the default one); where a method
has several such groups, each is labelled with the settings that tell them apart. Groups of
different methods may have learnt from different settings too: :func:`settings_between_groups`
names them, for the tables and figures to state.

Curves are noisy per iteration, so statistics use a trailing moving average over ``window``
iterations that reported a value; every statistic is computed per seed first and then
summarised as mean ± std over seeds (population std, ``ddof=0``). Unfinished runs are left out
of statistics unless asked for: a seed still in progress would cut the common range of a
method's curves short and lower its peak.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.config_file import read_config_file
from maopg.experiment.run.directory import CONFIG, DONE, FINAL_FRACTION, METRICS
from maopg.experiment.run.methods import get_method

RETURN = "episode_return"
PAPER_METRIC = "option_step_reward"


@dataclass
class RunData:
    """One run's identity and curves."""

    path: Path
    task: str
    method: str
    seed: int
    samples: np.ndarray
    """Low-level ticks at the end of each iteration."""
    metrics: dict[str, np.ndarray]
    """Column name → per-iteration values (``nan`` where the iteration had none)."""
    finished: bool
    config: dict[str, Any] = field(default_factory=dict)
    """The resolved ``config.json``, flattened to command-line keys (``ppo.lr``, ``env.jars``)."""

    def column(self, metric: str) -> np.ndarray:
        """The per-iteration values of ``metric``; a ``KeyError`` naming the file if the run
        does not log it."""
        if metric not in self.metrics:
            raise KeyError(f"{self.path / METRICS} has no column {metric!r}")
        return self.metrics[metric]

    def counted(self, counter: str) -> np.ndarray:
        """Each iteration's place on ``counter``: maopg's ``samples``, or a counter the run
        logs (ACAC's and MacroMARL's ``published_steps``; a ``KeyError`` if it logs none)."""
        return self.samples if counter == "samples" else self.column(counter)

    def curve(self, metric: str = RETURN, window: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """``(samples, values)`` of ``metric`` over iterations that reported it, smoothed by a
        trailing mean over the last ``window`` such iterations."""
        values = self.column(metric)
        seen = ~np.isnan(values)
        return self.samples[seen], trailing_mean(values[seen], window)


def trailing_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Mean of the last ``window`` values at each position (fewer at the start)."""
    if window < 1:
        raise ValueError(f"window must be >= 1, got {window}")
    cumsum = np.concatenate([[0.0], np.cumsum(values, dtype=np.float64)])
    idx = np.arange(1, len(values) + 1)
    start = np.maximum(idx - window, 0)
    return (cumsum[idx] - cumsum[start]) / (idx - start)


def load_run(run_dir: str | Path) -> RunData:
    """Read ``config.json`` and ``metrics.csv`` of one run directory (a run that has not
    finished an iteration yet has a header and no rows: empty curves)."""
    run_dir = Path(run_dir)
    config = read_config_file(run_dir / CONFIG)
    missing = [key for key in ("task", "method", "seed") if key not in config]
    if missing:
        raise ValueError(f"{run_dir / CONFIG} lacks {missing}")
    with (run_dir / METRICS).open(newline="") as handle:
        reader = csv.DictReader(handle)
        rows = list(reader)
        columns = reader.fieldnames or ()
    metrics = {
        name: np.array([float(r[name]) for r in rows], dtype=np.float64)
        for name in columns
        if name != "samples"
    }
    samples = np.array([float(r["samples"]) for r in rows], dtype=np.float64)
    return RunData(
        path=run_dir,
        task=str(config["task"]),
        method=str(config["method"]),
        seed=int(config["seed"]),
        samples=samples,
        metrics=metrics,
        finished=(run_dir / DONE).exists(),
        config=flatten_config(with_defaults(config)),
    )


def with_defaults(config: dict[str, Any]) -> dict[str, Any]:
    """``config`` with the settings it lacks filled in at today's defaults: the top-level ones
    and its method's section. A ``config.json`` written before a setting existed lacks it, and
    its run trained as the setting's default does (a new setting defaults to the old
    behaviour); unfilled, a run that sets it would be pooled, unlabelled, with runs that predate
    it. A method this process does not know (a plugin not imported) keeps its section as is."""
    defaults = {k: v for k, v in TrainConfig().to_dict().items() if not isinstance(v, dict)}
    filled = {**defaults, **config}
    try:
        method = get_method(str(config["method"]))
    except ValueError:
        return filled
    section = filled.get(method.section)
    if isinstance(section, dict):
        filled[method.section] = {**dataclasses.asdict(method.default_config()), **section}
    return filled


def flatten_config(config: dict[str, Any]) -> dict[str, Any]:
    """``{"ppo": {"lr": ..}, "env_overrides": {"jars": 8}}`` → ``{"ppo.lr": .., "env.jars": 8}``."""
    flat: dict[str, Any] = {}
    for key, value in config.items():
        prefix = "env" if key == "env_overrides" else key
        if isinstance(value, dict):
            flat.update({f"{prefix}.{k}": v for k, v in value.items()})
        else:
            flat[key] = value
    return flat


NOT_LEARNT = frozenset(
    {"task", "method", "seed", "run_dir", "plugins", "progress", "video", "plot", "logger"}
    | {"video_sample", "video_gif", "checkpoint_every", "backend", "num_workers", "device"}
    | {"torch_threads"}
    | {"eval_episodes", "eval_every", "eval_during_episodes", "eval_during_sample"}
)
"""Settings that identify a run or say where and how it ran and logged, not what it learnt
(every backend and worker count gives the same curve); the run sections' too."""
NOT_LEARNT_SECTIONS = ("ray.", "wandb.")
"""The run sections (``config.RUN_SECTIONS``: where a run runs and logs), as key prefixes."""


def learnt_settings(run: RunData) -> dict[str, Any]:
    """The run's settings that change what it learns (flattened keys)."""
    return {
        k: v
        for k, v in run.config.items()
        if k not in NOT_LEARNT and not k.startswith(NOT_LEARNT_SECTIONS)
    }


def task_settings(run: RunData) -> dict[str, Any]:
    """The run's task settings (its ``env.KEY=VALUE``), as ``make_env`` takes them."""
    return {k.removeprefix("env."): v for k, v in run.config.items() if k.startswith("env.")}


def _compared_keys(settings: Sequence[dict[str, Any]]) -> set[str]:
    """Every task setting (``env.*``; one a run does not set reads ``default``) and the other
    keys all of ``settings`` have: a key only some have (another method's section, or a config
    written by an older version) is not compared."""
    keys = {k for s in settings for k in s if k.startswith("env.")}
    return keys | (set.intersection(*(set(s) for s in settings)) if settings else set())


def differing_settings(settings: Sequence[dict[str, Any]]) -> list[str]:
    """The compared keys whose values differ between ``settings`` (one dict per run or group),
    sorted."""
    return sorted(
        k
        for k in _compared_keys(settings)
        if len({json.dumps(s.get(k, "default")) for s in settings}) > 1
    )


def _variant_labels(runs: Sequence[RunData]) -> list[str]:
    """For runs of one task and method: ``""`` for each if they share their settings, else
    each run's values of the settings that differ (``env.max_ticks=100``)."""
    settings = [learnt_settings(r) for r in runs]
    differ = differing_settings(settings)
    return [", ".join(f"{k}={s.get(k, 'default')}" for k in differ) for s in settings]


def shared_settings(runs: Sequence[RunData]) -> dict[str, Any]:
    """The learnt settings (keyed as :func:`differing_settings` compares them) that every run
    of a group has with the same value: what the group as a whole learnt from."""
    settings = [learnt_settings(r) for r in runs]
    differ = differing_settings(settings)
    return {
        k: settings[0].get(k, "default")
        for k in sorted(_compared_keys(settings))
        if k not in differ
    }


def _foreign_sections(method: str) -> tuple[str, ...]:
    """Key prefixes of the learner sections ``method`` does not use (``dqn.`` for ``async``):
    configs of an older version saved every section, and another method's hyper-parameters
    are nothing a run learnt from. None for a method that is not registered here (a plugin's
    that is not imported). The registry is imported here only: it brings torch, which the
    curves and tables need nowhere else."""
    from maopg.experiment.run.methods import get_method, section_classes

    try:
        own = get_method(method).section
    except ValueError:
        return ()
    return tuple(f"{name}." for name in section_classes() if name != own)


def settings_between_groups(
    groups: dict[str, Sequence[RunData]],
) -> list[tuple[str, dict[str, Any]]]:
    """For the groups of one task (label → runs): each learnt setting whose value differs
    between them, with every group's value (``default`` for a task setting a group does not
    set), in key order — what a reader must know before comparing the groups' rows or lines.
    Empty when they all learnt from the same settings (or there is one group)."""
    if len(groups) < 2:
        return []
    shared = {}
    for label, runs in groups.items():
        foreign = _foreign_sections(runs[0].method)
        settings = shared_settings(runs)
        shared[label] = {k: v for k, v in settings.items() if not k.startswith(foreign)}
    return [
        (key, {label: s.get(key, "default") for label, s in shared.items()})
        for key in differing_settings(list(shared.values()))
    ]


def differences_line(groups: dict[str, Sequence[RunData]]) -> str:
    """:func:`settings_between_groups` in words (``""`` when there are none):
    ``hidden (async 128, sync-cut 32); env.max_ticks (async default, sync-cut 100)``."""
    return "; ".join(
        f"{key} ({', '.join(f'{label} {value}' for label, value in values.items())})"
        for key, values in settings_between_groups(groups)
    )


def discover_runs(roots: Iterable[str | Path], *, unfinished: bool = False) -> list[RunData]:
    """Every finished run directory (``config.json`` + ``metrics.csv`` + ``done.json``) under
    ``roots``, sorted; with ``unfinished``, runs in progress too."""
    found: dict[Path, RunData] = {}
    for root in roots:
        root = Path(root)
        if not root.exists():
            raise FileNotFoundError(f"run directory root {root} does not exist")
        for metrics in sorted(root.rglob(METRICS)):
            if (metrics.parent / CONFIG).exists():
                run = load_run(metrics.parent)
                if run.finished or unfinished:
                    found[metrics.parent.resolve()] = run
    return sorted(found.values(), key=lambda r: (r.task, r.method, r.seed, str(r.path)))


def group_runs(runs: Iterable[RunData]) -> dict[tuple[str, str], list[RunData]]:
    """``(task, label)`` → runs (seeds), ordered by task then method. The label is the method,
    or ``method [settings]`` where the method's runs differ in what they learnt from (module
    docstring): those are separate groups, never seeds of one."""
    by_method: dict[tuple[str, str], list[RunData]] = defaultdict(list)
    for run in sorted(runs, key=lambda r: (r.task, r.method, r.seed)):
        by_method[(run.task, run.method)].append(run)
    groups: dict[tuple[str, str], list[RunData]] = {}
    for (task, method), members in by_method.items():
        labels = _variant_labels(members)
        for label in sorted(set(labels)):
            name = f"{method} [{label}]" if label else method
            groups[(task, name)] = [
                r for r, lab in zip(members, labels, strict=True) if lab == label
            ]
    return groups


def base_method(label: str) -> str:
    """The method of a group label (``"async [env.max_ticks=100]"`` → ``"async"``)."""
    return label.split(" [", 1)[0]


# ----------------------------------------------------------------------------- statistics
@dataclass(frozen=True)
class Summary:
    """Mean ± std over the seeds that contributed (``nan`` values are left out), and how many
    did."""

    mean: float
    std: float
    count: int

    @staticmethod
    def of(values: Sequence[float]) -> Summary:
        arr = np.asarray([v for v in values if not math.isnan(v)], dtype=np.float64)
        if arr.size == 0:
            return Summary(math.nan, math.nan, 0)
        return Summary(float(arr.mean()), float(arr.std()), int(arr.size))


def peak(run: RunData, metric: str = RETURN, window: int = 1) -> float:
    """Best smoothed value of ``metric`` in the run (``nan`` if it never reported one)."""
    _, values = run.curve(metric, window)
    return float(values.max()) if values.size else math.nan


def final(run: RunData, metric: str = RETURN, fraction: float = FINAL_FRACTION) -> float:
    """Mean per-iteration ``metric`` over the last ``fraction`` of the run's samples (``nan`` if
    none reported there): where training ended, which a peak alone does not tell."""
    rows = final_iterations(run, metric, fraction)
    # The curve's values (over the rows that reported the metric) are what the tables have
    # always averaged: a trailing mean of one differs from the logged value in its last bits.
    tail = run.curve(metric)[1][rows[~np.isnan(run.column(metric))]]
    return float(tail.mean()) if tail.size else math.nan


def final_iterations(
    run: RunData, metric: str = RETURN, fraction: float = FINAL_FRACTION
) -> np.ndarray:
    """The iterations :func:`final` averages, as a mask over the run's rows: those in the last
    ``fraction`` of its samples that reported ``metric``. A measurement built on the final
    figure that needs more of those rows (``bench/analysis/target_odds.py``: the episodes each
    ended) reads the very same ones."""
    if not run.samples.size:
        return np.zeros(0, dtype=bool)
    in_tail = run.samples > run.samples[-1] * (1.0 - fraction)
    return in_tail & ~np.isnan(run.column(metric))


def samples_to_threshold(
    run: RunData, threshold: float, metric: str = RETURN, window: int = 1
) -> float:
    """Low-level samples at the first iteration whose smoothed ``metric`` ≥ ``threshold``
    (``nan`` if never)."""
    samples, values = run.curve(metric, window)
    hits = np.flatnonzero(values >= threshold)
    return float(samples[hits[0]]) if hits.size else math.nan


def mean_curve(
    runs: Sequence[RunData], metric: str = RETURN, window: int = 1, points: int = 200
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(samples, mean, std)`` over seeds on a common grid of low-level samples.

    Seeds' iterations end at slightly different sample counts (and report their first episode
    return at different ones), so each smoothed curve is linearly interpolated onto a grid over
    the range **every** seed covers: outside it a "mean over seeds" would be one seed's value
    and jump. Seeds that share no range at all (one reported returns only early, another only
    late) still give a line: over the range any covers, each point the mean of the seeds that
    cover it. Empty arrays when no seed reported a value.
    """
    curves = [c for c in (r.curve(metric, window) for r in runs) if c[0].size]
    if not curves:
        return np.empty(0), np.empty(0), np.empty(0)
    lo = max(float(s[0]) for s, _ in curves)
    hi = min(float(s[-1]) for s, _ in curves)
    if hi < lo:
        lo = min(float(s[0]) for s, _ in curves)
        hi = max(float(s[-1]) for s, _ in curves)
    grid = np.linspace(lo, hi, points) if hi > lo else np.array([lo])
    stacked = np.stack([np.interp(grid, s, v, left=np.nan, right=np.nan) for s, v in curves])
    covered = ~np.isnan(stacked).all(axis=0)  # points between disjoint seeds' ranges: none
    grid, stacked = grid[covered], stacked[:, covered]
    return grid, np.nanmean(stacked, axis=0), np.nanstd(stacked, axis=0)

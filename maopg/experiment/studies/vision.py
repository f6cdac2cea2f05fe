"""The vision study: does training under randomised looks keep a policy from cameras working in
looks it never saw, and what does it cost in the looks it trained on?
(``python -m eval reproduce --study vision``; ``results/vision/``.)

**Variants.** ``async`` from RGB (``images=true``, the tasks' 64-pixel cameras), 3 seeds, on
Tool Delivery (100K samples) and Water Filling (200K), at each task's defaults but its looks:
trained with ``env.appearance=off`` (the scenes as their tasks build them) and with ``full``
(colours, textures, lights, camera poses and distractors drawn afresh every episode,
:mod:`maopg.sim.looks`). Two pilots on Tool Delivery, one seed each, train with ``full`` too:
from depth alone (``env.camera_channels=depth``) and from RGB and depth (``rgb+depth``).
``full``, not ``off``: depth is blind to colours and lights but not to the jittered cameras
and the distractors, so a pilot trained under ``full`` asks what depth keeps of the robustness
``full`` trains for, where one trained under ``off`` would meet those for the first time in
the held-out looks. Depth sees little of ``heldout`` (colours and lights); what it can meet
anew is geometric, which ``mounts`` holds out: each camera turned and moved further on its mount
than training ever does (:mod:`maopg.sim.look_draws`).

Each variant is a :class:`~maopg.experiment.studies.registry.Study` of its own (a task
appears once in a study, and here each is trained under two looks) with its own run root,
``results/vision/runs/<variant>/<task>/async/seed<N>``, brought to completion by
:func:`~maopg.experiment.studies.grid.run_grid` as every study's grid is: resumable, each cell
locked while it trains, ``--jobs`` at a time. Tool Delivery's cells train first, every
variant's, then Water Filling's: the cheaper task's answer comes first.

**Evaluation.** Each finished run's final policy plays :data:`EPISODES` episodes in its own
looks (in-distribution: the ``env.appearance`` it trained with, ``off`` or ``full``) and as many
in ``heldout`` looks (palettes, textures and lights no training look draws, the cameras
jittered as in training: :mod:`maopg.sim.look_draws`), the looks the targets read, and as many
in ``mounts`` (``full``'s looks with each camera turned and moved on its mount further than
training does: the geometry a depth camera sees, reported without a target),
:func:`~maopg.experiment.evaluation.evaluate.evaluate` on reset seeds 0, 1, ...: the same
episodes for every run and look (under ``full``, ``heldout`` and ``mounts`` each seed draws a
look of its own), none of them a training episode's (a training reset seed is a
32-bit hash, :func:`maopg.env.vector_base.episode_seed`; ``tests/experiment/test_vision_study.py``
checks the study's runs). It acts both ways: greedy, the
project's default (:data:`~maopg.experiment.evaluation.GREEDY_BY_DEFAULT`), and sampled, as it
trained — Water Filling's feed-forward greedy policies loop (results/README.md, Water Filling
finding 6), where a greedy score near 0 in every look would make the targets' ratios noise;
the targets are worked out on each, and the verdict is read on sampled acting
(:data:`PRIMARY_ACTING`, declared before any run finished). The summaries are cached in the
run directory's :data:`EVALUATION`, keyed as every cached evaluation
(:mod:`~maopg.experiment.studies.cache`), on the weights and the looks' version too. Git
keeps that file for every seed but the weights of seed 0 only, so a clean clone redraws the
tables from the stored numbers of the seeds whose weights it lacks.

**Scores.** A return ``R`` is read as ``(R − R_random) / (R_scripted − R_random)`` against the
uniform-random and scripted policies of the task at its default settings over
:data:`REFERENCE_EPISODES` episodes each. They act from state, and a look never changes the
physics (``tests/sim/test_appearance.py``), so one pair of levels per task serves every look;
cached in ``results/vision/references/<task>.json``. Per task, variant and acting: the mean over
seeds with a percentile bootstrap 95 % interval, and every seed's, in-distribution, held-out
and with the mounts held out; then the targets on the seed means — trained with ``full``, its
in-distribution score at least :data:`TARGET_IN` × the ``off``-trained policy's and its
``heldout`` score at least :data:`TARGET_HELDOUT` × its own in-distribution one — each marked
met or missed (no verdict on a base not above random), on how many seeds each mean stands, and
how far the ``off``-trained policy falls in the held-out looks. The training curves of every variant
(one figure per task) and their final training returns, normalised alike, come with them.

**Cost**, measured by ``bench/perf/vision_cost.py --samples td=2000,wf=4000`` (BENCHMARKS.md,
"The vision study's cost"; short runs side by side on 2 shared cores at load 7.0): per 100K
samples, Tool Delivery 786 CPU-seconds with ``off`` and 778 with ``full``, Water Filling 784
and 886; an evaluation episode 1.0–1.3 CPU-seconds on Tool Delivery and 1.8–1.9 on Water
Filling. The 14 runs and their evaluations in three looks project to 5.2 CPU-hours (start-up
counted per short run: an upper bound); the evaluations are 12–22 % of a run's training.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from maopg.experiment.evaluation.evaluate import evaluate
from maopg.experiment.run.directory import FINAL
from maopg.experiment.run.lock import held_elsewhere
from maopg.experiment.studies.cache import cached, stored, weights_key
from maopg.experiment.studies.grid import BUSY, Cell, run_grid
from maopg.experiment.studies.plots import plot_task
from maopg.experiment.studies.registry import VISION, Study, StudyTask, frozen
from maopg.experiment.studies.results import reference_levels
from maopg.experiment.studies.runs import RunData, discover_runs, task_settings
from maopg.experiment.studies.tables import markdown_table, mean_interval, normalised_table
from maopg.sim.look_draws import LOOKS_VERSION
from maopg.sim.looks import HELDOUT, MOUNTS, OFF

if TYPE_CHECKING:
    from maopg.experiment.evaluation.loading import Trained

METHOD = "async"
SEEDS = (0, 1, 2)
BUDGETS: Mapping[str, int] = frozen({"tool_delivery": 100_000, "water_filling": 200_000})
"""Each task's samples: its default budget, the paper grid's."""
PILOT_TASK = "tool_delivery"
"""The pilots' task: the cheaper one (half the samples, and a run takes 13–17 minutes against
Water Filling's 23: the cost below)."""
OFF_VARIANT, FULL_VARIANT = "off", "full"
"""The variants the targets compare."""
EPISODES = 20
"""Episodes of each evaluation (one look, one way of acting)."""
ACTINGS = (("greedy", True), ("sampled", False))
"""How a policy acts in its evaluations (module docstring): name, greedy."""
PRIMARY_ACTING = "sampled"
"""The acting the targets' verdict is read on, declared before any result: the policy as it
trained, which its training curves show, where greedy Water Filling policies loop (module
docstring); the greedy rows are reported beside it."""
EVALUATION = "vision_evaluation.json"
"""A run's cached evaluations in its own looks and the held-out ones (:func:`evaluated_looks`)."""
REFERENCE_EPISODES = 100
"""Episodes of each reference policy a task's normalising levels average."""
TARGET_IN = 0.8
"""Trained with ``full``, its in-distribution score is at least this × the ``off``-trained's."""
TARGET_HELDOUT = 0.9
"""Trained with ``full``, its held-out score is at least this × its in-distribution score."""


@dataclass(frozen=True)
class Variant:
    """One way of training the study's policies: a study of its own, in ``<runs>/<name>``."""

    name: str
    study: Study
    pilot: bool = False

    def tasks(self) -> list[str]:
        return [t.task for t in self.study.tasks]


def variant(
    name: str,
    appearance: str,
    channels: str = "rgb",
    *,
    tasks: Sequence[str] = tuple(BUDGETS),
    seeds: Sequence[int] = SEEDS,
    pilot: bool = False,
) -> Variant:
    """``async`` from the cameras' ``channels`` trained with ``env.appearance=appearance`` on
    ``tasks`` at their budgets. Both settings are written out, the defaults too, so every run's
    ``config.json`` and every curve's label names them."""
    settings = frozen({"appearance": appearance, "camera_channels": channels})
    study = Study(
        f"{VISION}-{name}",
        f"async from {channels} trained with env.appearance={appearance}",
        tuple(
            StudyTask(t, tuple(seeds), settings, frozen({"total_samples": BUDGETS[t]}))
            for t in tasks
        ),
        (METHOD,),
        overrides=frozen({"images": True}),
    )
    return Variant(name, study, pilot)


VARIANTS = (
    variant(OFF_VARIANT, OFF),
    variant(FULL_VARIANT, "full"),
    variant("depth", "full", "depth", tasks=(PILOT_TASK,), seeds=(0,), pilot=True),
    variant("rgb-depth", "full", "rgb+depth", tasks=(PILOT_TASK,), seeds=(0,), pilot=True),
)
"""The committed study (module docstring)."""


LOOK_SETTINGS = ("appearance", "camera_channels")
"""The task settings the variants differ in: how the scenes look and what the cameras return,
neither of which the reference policies (acting from state) nor the physics see."""


def reference_task(variants: Sequence[Variant], task: str) -> StudyTask:
    """``task`` at the settings every variant trains it at but the looks: where its reference
    policies are measured, once for every variant. ``ValueError`` if the variants' other
    settings differ (their scores would then need levels of their own)."""
    found = {
        json.dumps({k: v for k, v in s.items() if k not in LOOK_SETTINGS}, sort_keys=True)
        for s in (v.study.task(task).settings for v in variants if task in v.tasks())
    }
    if len(found) != 1:
        raise ValueError(f"the vision variants train {task} at other settings: {sorted(found)}")
    return StudyTask(task, (), frozen(json.loads(found.pop())))


# ------------------------------------------------------------------------------- per run
def trained_look(run: RunData) -> str:
    """The ``env.appearance`` a run trained with: its in-distribution looks."""
    return str(task_settings(run).get("appearance", OFF))


HELD_OUT_LOOKS = (HELDOUT, MOUNTS)
"""The looks no policy trained in, where every policy is evaluated too."""


def evaluated_looks(run: RunData) -> tuple[str, ...]:
    """The looks a run's policy is evaluated in: its own, then :data:`HELD_OUT_LOOKS`."""
    return (trained_look(run), *HELD_OUT_LOOKS)


def policy_looks(trained: Trained, run: RunData, episodes: int) -> list[dict]:
    """A run's final policy in :func:`evaluated_looks`, greedy and sampled, over the same
    seeded episodes: one summary each, with its ``look`` and ``acting``."""
    results = []
    for look in evaluated_looks(run):
        env = trained.make_env(0, {"appearance": look})
        try:
            for acting, greedy in ACTINGS:
                actor = trained.actor(greedy=greedy, seed=0)
                label = f"{run.method} seed{run.seed} {acting}, {look} looks"
                summary = evaluate(env, actor, episodes, label=label).summary
                results.append({**summary, "look": look, "acting": acting})
        finally:
            env.close()
    return results


def run_evaluation(run: RunData, episodes: int) -> list[dict] | None:
    """:func:`policy_looks` of a run, cached in its :data:`EVALUATION`; where its weights are
    gone, what that file stores (``None``: nothing)."""
    from maopg.experiment.evaluation.loading import load_trained

    path, weights = run.path / EVALUATION, run.path / FINAL
    if not weights.exists():  # stored numbers stand for it, if of the looks drawn now
        return stored(path, {"looks_version": LOOKS_VERSION})
    trained = load_trained(weights)
    key = {
        **weights_key(episodes, run.task, type(trained.policy), weights),
        "looks": list(evaluated_looks(run)),
        "looks_version": LOOKS_VERSION,
    }
    return cached(path, key, lambda: policy_looks(trained, run, episodes))


@dataclass(frozen=True)
class Outcome:
    """One run's final policy, acting one way, in its own looks, in ``heldout`` and in
    ``mounts`` (``nan``: not evaluated)."""

    variant: str
    task: str
    seed: int
    acting: str
    look: str
    """The looks it trained with."""
    own_return: float
    heldout_return: float
    mounts_return: float
    own: float
    """Normalised score in its own looks."""
    heldout: float
    """Normalised score in the held-out looks (colours, textures, lights)."""
    mounts: float
    """Normalised score with the cameras moved further on their mounts than in training."""
    episodes: int
    """Episodes of each of its evaluations, one per look (0: not evaluated)."""


def outcomes(
    name: str, runs: Sequence[RunData], levels: Mapping[str, tuple[float, float]], episodes: int
) -> list[Outcome]:
    """Each run of variant ``name`` and each way of acting, scored against its task's
    ``(random, scripted)`` ``levels``."""
    out = []
    for run in runs:
        summaries = run_evaluation(run, episodes) or []
        look = trained_look(run)
        random, scripted = levels[run.task]
        for acting, _ in ACTINGS:
            found = {s["look"]: s for s in summaries if s["acting"] == acting}
            returns = [
                found[k]["return_mean"] if k in found else math.nan for k in evaluated_looks(run)
            ]
            score = [(r - random) / (scripted - random) for r in returns]
            played = found[look]["episodes"] if look in found else 0
            out.append(Outcome(name, run.task, run.seed, acting, look, *returns, *score, played))
    return out


# ------------------------------------------------------------------------------- tables
def _mean(values: Sequence[float]) -> float:
    kept = [v for v in values if not math.isnan(v)]
    return float(np.mean(kept)) if kept else math.nan


def _score(value: float) -> str:
    return f"{value:.2f}"


def task_table(task: str, variants: Sequence[Variant], rows: Sequence[Outcome]) -> str:
    """One task: per variant that trains on it and way of acting, the normalised score in its
    own looks, in the held-out ones and with the cameras' mounts held out (mean, bootstrap 95 %
    interval), the held-out difference, and every seed's."""
    table = []
    for v in (v for v in variants if task in v.tasks()):
        settings = v.study.task(task).settings
        label = [v.name + (" (pilot)" if v.pilot else ""), settings["appearance"]]
        label.append(settings["camera_channels"])
        for acting, _ in ACTINGS:
            mine = sorted(
                (r for r in rows if (r.variant, r.task, r.acting) == (v.name, task, acting)),
                key=lambda r: r.seed,
            )
            if not mine:
                table.append([*label, acting, "0", "—", "—", "—", "—", "not run yet"])
                continue
            each = ", ".join(
                f"seed{r.seed} "
                + (
                    "not evaluated"
                    if math.isnan(r.own)
                    else f"{r.own:.2f} → {r.heldout:.2f}, {r.mounts:.2f}"
                )
                for r in mine
            )
            table.append(
                [
                    *label,
                    acting,
                    str(len(mine)),
                    mean_interval([r.own for r in mine], _score),
                    mean_interval([r.heldout for r in mine], _score),
                    mean_interval([r.heldout - r.own for r in mine], "{:+.2f}".format),
                    mean_interval([r.mounts for r in mine], _score),
                    each,
                ]
            )
    header = [
        "variant",
        "trained with",
        "channels",
        "acting",
        "seeds",
        "in-distribution [95 % CI]",
        "held-out [95 % CI]",
        "held-out − in-distribution [95 % CI]",
        "mounts held out [95 % CI]",
        "each seed: in-distribution → held-out, mounts",
    ]
    return markdown_table(header, table)


def _target(value: float, factor: float, base: float) -> str:
    """``value ≥ factor × base``, worked out and marked; ``—`` where a side is missing, and no
    verdict where ``base`` is at or below the random policy's 0 (a ratio of it tests
    nothing: any score would meet it)."""
    if math.isnan(value) or math.isnan(base):
        return "— (not run yet)"
    if base <= 0:
        return f"{value:.2f} vs {factor:g} × {base:.2f}: no verdict (the base is not above random)"
    need = factor * base
    verdict = "**met**" if value >= need else "**missed**"
    return f"{value:.2f} vs {factor:g} × {base:.2f} = {need:.2f}: {verdict}"


def _drop(own: float, held: float) -> str:
    """How far the held-out score falls below the in-distribution one."""
    if math.isnan(own) or math.isnan(held):
        return "— (not run yet)"
    share = ""
    if held <= 0:
        share = "; held out at or below the random policy"
    elif own > 0:
        share = f"; keeps {held / own:.0%}"
    return f"{held - own:+.2f} ({own:.2f} → {held:.2f}{share})"


def _seeds(rows: Sequence[Outcome], name: str, task: str, acting: str) -> list[Outcome]:
    """The evaluated runs of variant ``name`` on ``task`` acting one way."""
    return [
        r
        for r in rows
        if (r.variant, r.task, r.acting) == (name, task, acting) and not math.isnan(r.own)
    ]


def targets_table(
    tasks: Sequence[str], rows: Sequence[Outcome], seeds: Mapping[str, int] | None = None
) -> str:
    """Per task and way of acting: the targets on the seed means (module docstring), the
    seeds each mean stands on (``provisional`` until both variants have all the task's
    ``seeds``, default :data:`SEEDS`), and the ``off``-trained policy's fall in the held-out
    looks. The verdict is the :data:`PRIMARY_ACTING` row's; the other is reported beside it."""
    table = []
    for task in tasks:
        for acting, _ in ACTINGS:
            off, full = (_seeds(rows, v, task, acting) for v in (OFF_VARIANT, FULL_VARIANT))
            off_own, off_held = (_mean([getattr(r, f) for r in off]) for f in ("own", "heldout"))
            full_own, full_held = (_mean([getattr(r, f) for r in full]) for f in ("own", "heldout"))
            planned = (seeds or {}).get(task, len(SEEDS))
            counted = f"{len(off)} / {len(full)} of {planned}"
            if min(len(off), len(full)) < planned:
                counted += " (provisional)"
            role = "primary" if acting == PRIMARY_ACTING else "reported"
            table.append(
                [
                    task,
                    f"{acting} ({role})",
                    counted,
                    _target(full_own, TARGET_IN, off_own),
                    _target(full_held, TARGET_HELDOUT, full_own),
                    _drop(off_own, off_held),
                    _drop(full_own, full_held),
                ]
            )
    header = [
        "task",
        "acting",
        "seeds `off` / `full`",
        f"`full` in-distribution ≥ {TARGET_IN:g} × `off` in-distribution",
        f"`full` held-out ≥ {TARGET_HELDOUT:g} × `full` in-distribution",
        "`off`: held-out − in-distribution",
        "`full`: held-out − in-distribution",
    ]
    return markdown_table(header, table)


# ------------------------------------------------------------------------------- reproduce
def reproduce_vision(
    results_dir: str | Path = Path("results", VISION),
    *,
    runs_root: str | Path | None = None,
    variants: Sequence[Variant] = VARIANTS,
    tasks: Sequence[str] | None = None,
    train: bool = True,
    episodes: int = EPISODES,
    reference_episodes: int = REFERENCE_EPISODES,
    window: int = 5,
    log: Callable[[str], None] = print,
    **grid_kw,
) -> tuple[dict[tuple[str, Cell], str], list[Path]]:
    """Bring every variant's cells on ``tasks`` (default: all) to finished, task by task, in
    ``<runs_root>/<variant>`` (default ``<results>/runs``), then evaluate each finished run's
    final policy (cached) and write ``tables.md``, ``scores.csv`` and each task's curves from
    every logged run. Returns each cell's outcome (by variant) and the files written;
    ``grid_kw``: :func:`~maopg.experiment.studies.grid.run_grid`'s ``jobs``, ``dry_run``,
    ``in_process``, ... A ``dry_run`` writes nothing; while other processes still train some
    cells, the results wait for the one that ends last."""
    out = Path(results_dir)
    root = Path(runs_root) if runs_root is not None else out / "runs"
    known = list(dict.fromkeys(t for v in variants for t in v.tasks()))
    chosen = list(tasks) if tasks is not None else known
    unknown = [t for t in chosen if t not in known]
    if unknown:
        raise ValueError(f"task(s) {unknown} not in study {VISION!r}; choose from {known}")
    cells: dict[tuple[str, Cell], str] = {}
    for task in chosen if train else ():
        for v in (v for v in variants if task in v.tasks()):
            log(f"{v.name}: {task} in {root / v.name}")
            done = run_grid(root / v.name, study=v.study, tasks=[task], log=log, **grid_kw)
            cells.update({(v.name, cell): outcome for cell, outcome in done.items()})
    if grid_kw.get("dry_run"):
        return cells, []
    busy = [
        c for (name, c), o in cells.items() if o == BUSY and held_elsewhere(c.run_dir(root / name))
    ]
    if busy:
        log(f"results not redrawn: {len(busy)} cell(s) still training in other processes")
        return cells, []
    out.mkdir(parents=True, exist_ok=True)
    found = {
        v.name: discover_runs([root / v.name]) if (root / v.name).exists() else [] for v in variants
    }
    runs = [r for name in found for r in found[name]]
    levels = {
        task: reference_levels(
            reference_task(variants, task), out / "references" / f"{task}.json", reference_episodes
        )
        for task in known
        if any(r.task == task for r in runs)
    }
    rows = [o for v in variants for o in outcomes(v.name, found[v.name], levels, episodes)]
    written = _write_curves(runs, levels, out, window)
    written.append(
        _write_tables(variants, known, rows, runs, levels, episodes, reference_episodes, out)
    )
    written.append(_write_scores(rows, out / "scores.csv"))
    return cells, written


def _write_curves(
    runs: Sequence[RunData], levels: Mapping[str, tuple[float, float]], out: Path, window: int
) -> list[Path]:
    """Each task's training curves, every variant's a line of its own (their labels name the
    looks and channels they trained with), against the task's scripted and random levels."""
    written = []
    for task in sorted({r.task for r in runs}):
        random, scripted = levels[task]
        written += plot_task(
            [r for r in runs if r.task == task],
            out / f"curves_{task}",
            window=window,
            title=f"{task}: async trained under each look",
            references={"scripted": scripted, "random": random},
        )
    return written


def _write_tables(
    variants: Sequence[Variant],
    tasks: Sequence[str],
    rows: Sequence[Outcome],
    runs: Sequence[RunData],
    levels: Mapping[str, tuple[float, float]],
    episodes: int,
    reference_episodes: int,
    out: Path,
) -> Path:
    """``tables.md``: the targets, each task's scores and curves, the final training returns."""
    counts = sorted({r.episodes for r in rows if r.episodes}) or [episodes]
    played = " or ".join(map(str, counts))
    sections = [
        "# The vision study\n\nGenerated by `python -m eval reproduce --study vision` from the "
        "logged runs and their cached evaluations (the protocol: "
        "`maopg.experiment.studies.vision`). `async` from cameras, trained with "
        "`env.appearance=off` or `full`; each final policy plays "
        f"{played} episodes (reset seeds 0, 1, ...) in the looks it trained with "
        "(in-distribution), as many in `heldout` looks (colours, textures and lights never "
        "drawn in training; the cameras jittered and distractors stood as in `full`) and as "
        "many in `mounts` (`full`'s looks with the cameras turned and moved on their mounts "
        "further than training does: for an `off`-trained policy, `full`'s looks are new too), "
        "greedy and sampled. "
        "Scores are "
        "normalised, (R − R_random) / (R_scripted − R_random), against the task's random and "
        "scripted policies; intervals: percentile bootstrap 95 % over seeds.\n",
        "## Targets\n\nOn the seed means of the `off` and `full` variants; the verdict is "
        f"read on {PRIMARY_ACTING} acting (declared before the runs: "
        "`maopg.experiment.studies.vision.PRIMARY_ACTING`), the other reported beside it. "
        "A target whose base is not above the random policy gives no verdict.\n\n"
        + targets_table(tasks, rows, _planned_seeds(variants)),
    ]
    for task in tasks:
        if task in levels:
            random, scripted = levels[task]
            about = (
                f"Levels: random {random:.1f}, scripted {scripted:.1f} (strategy `continue`, "
                f"the task's settings but its looks, {reference_episodes} episodes each).\n\n"
            )
            figure = f"\n![{task} curves](curves_{task}.png)\n"
        else:
            about, figure = "No runs yet.\n\n", ""
        sections.append(f"## {task}\n\n{about}{task_table(task, variants, rows)}{figure}")
    if runs:
        sections.append(
            "## Training: final return\n\nThe mean training-episode return over each run's last "
            "10 % of samples, in the looks it trained with, normalised alike.\n\n"
            + normalised_table(runs, levels)
        )
    path = out / "tables.md"
    path.write_text("\n".join(sections).rstrip("\n") + "\n")
    return path


def _planned_seeds(variants: Sequence[Variant]) -> dict[str, int]:
    """Per task, the seeds the ``off`` and ``full`` variants both plan."""
    planned: dict[str, int] = {}
    for v in variants:
        if v.name in (OFF_VARIANT, FULL_VARIANT):
            for t in v.study.tasks:
                planned[t.task] = min(planned.get(t.task, len(t.seeds)), len(t.seeds))
    return planned


def _write_scores(rows: Sequence[Outcome], path: Path) -> Path:
    """Every run's figures, one line per way of acting, for other tools."""
    lines = [
        "variant,task,seed,acting,trained_look,episodes,return,heldout_return,mounts_return,"
        "normalised,heldout_normalised,mounts_normalised"
    ]
    lines += [
        f"{r.variant},{r.task},{r.seed},{r.acting},{r.look},{r.episodes},{r.own_return:.4f},"
        f"{r.heldout_return:.4f},{r.mounts_return:.4f},{r.own:.4f},{r.heldout:.4f},"
        f"{r.mounts:.4f}"
        for r in rows
    ]
    path.write_text("\n".join(lines) + "\n")
    return path

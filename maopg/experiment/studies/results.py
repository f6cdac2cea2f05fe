"""A study's results: its figures, tables and evaluation, regenerated from its finished runs.

:func:`reproduce` brings the study's grid to completion (:func:`~maopg.experiment.studies.grid.
run_grid`), then writes into its results folder: per-task learning curves (all methods, and
the Fig. 4 methods), their CSV, ``tables.md`` (peak, final, samples to the study's thresholds,
Table I and II analogs, the normalised score where the study asks for it; the evaluation
during training beside the published curves where it names them,
:mod:`maopg.experiment.studies.published`) and
``evaluation.md``: the reference policies and every method's seed-0 policy over seeded
episodes (the levels the curves are read against, and greedy vs sampled action choice), each
evaluation cached (:mod:`maopg.experiment.studies.cache`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from maopg.experiment.evaluation.evaluate import evaluate, results_table
from maopg.experiment.run.directory import FINAL
from maopg.experiment.run.lock import held_elsewhere
from maopg.experiment.studies.cache import behaviour, cached, weights_key
from maopg.experiment.studies.grid import BUSY, Cell, run_grid
from maopg.experiment.studies.plots import curve_table, plot_task
from maopg.experiment.studies.published import plot_published, published_sections
from maopg.experiment.studies.registry import PAPER, Study, StudyTask, get_study
from maopg.experiment.studies.runs import RunData, differing_settings, discover_runs, task_settings
from maopg.experiment.studies.tables import normalised_table, peak_table, threshold_table

if TYPE_CHECKING:
    from maopg.experiment.evaluation.loading import Trained

REFERENCE_STRATEGIES = ("continue", "any", "all")
EVALUATION = "evaluation.json"
"""A seed-0 run's cached entry of ``evaluation.md``."""
FIG4_METHODS = ("async", "sync-cut", "sync-wait", "end2end")
TABLE1_METHODS = ("async", "mac-dqn")
TABLE2_METHODS = ("async", "partial")


def write_results(
    runs: Sequence[RunData],
    results_dir: str | Path,
    *,
    thresholds: Mapping[str, float],
    window: int = 5,
    references: Mapping[str, tuple[float, float]] | None = None,
    normalised: bool = False,
    published: str | None = None,
) -> list[Path]:
    """Regenerate every figure, curve CSV and table of ``runs`` into ``results_dir``
    (``thresholds``: each task's return threshold, where it has one; ``references``: each
    task's random and scripted return, drawn as reference lines and, in a ``normalised``
    study, its scores' scale; ``published``: the published curves the runs' evaluations
    during training are set beside, first in the tables and in ``published_<task>``)."""
    out = Path(results_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for task in sorted({r.task for r in runs}):
        task_runs = [r for r in runs if r.task == task]
        lines = None
        if references and task in references:
            random, scripted = references[task]
            lines = {"scripted": scripted, "random": random}
        written += plot_task(task_runs, out / f"curves_{task}", window=window, references=lines)
        if any(r.method in FIG4_METHODS for r in task_runs):
            written += plot_task(
                task_runs,
                out / f"fig4_{task}",
                window=window,
                methods=FIG4_METHODS,
                title=f"{task}\nasync vs synchronous baselines and end2end (Fig. 4 analog)",
                references=lines,
            )
        if published:
            written += plot_published(task_runs, out / f"published_{task}", published)
        csv_path = out / f"curves_{task}.csv"
        csv_path.write_text(curve_table(task_runs, window=window))
        written.append(csv_path)
    sections = [
        ("Peak performance (mean ± std over seeds)", peak_table(runs, window=window)),
        (
            "Samples to threshold",
            threshold_table(runs, thresholds, window=window),
        ),
    ]
    analogs = (
        ("Table I analog: async vs Mac-DQN", TABLE1_METHODS),
        ("Table II analog: partially centralized vs centralized (async)", TABLE2_METHODS),
    )
    for title, methods in analogs:  # a paper table's analog, on the tasks where both ran
        tasks = {
            t
            for t in {r.task for r in runs}
            if {r.method for r in runs if r.task == t}.issuperset(methods)
        }
        paired = [r for r in runs if r.task in tasks]
        if paired:
            sections.append(
                (
                    title,
                    peak_table(paired, window=window, methods=methods)
                    + "\n"
                    + threshold_table(paired, thresholds, window=window, methods=methods),
                )
            )
    if normalised and references:
        title = "Normalised final score: (R − R_random) / (R_scripted − R_random)"
        sections.insert(0, (title, normalised_table(runs, references)))
    if published:
        sections[:0] = published_sections(runs, published)
    text = "# Results\n\nGenerated by `python -m eval reproduce` from the finished run "
    text += f"directories. Curves are smoothed by a trailing mean over {window} iterations "
    text += "before peaks and thresholds are taken; the final return is the unsmoothed mean "
    text += "over the last 10% of a run's samples.\n"
    for title, table in sections:
        text += f"\n## {title}\n\n{table}"
    tables = out / "tables.md"
    tables.write_text(text)
    written.append(tables)
    return written


def reference_results(
    tasks: Sequence[StudyTask],
    episodes: int,
    strategies: Sequence[str] = REFERENCE_STRATEGIES,
    *,
    progress: bool = False,
) -> list[dict]:
    """The scripted and uniform-random policies of each task (at its study settings) under
    each strategy: the levels every learning curve is read against (state observations:
    neither policy looks at images; ``progress``: a bar over each one's episodes on stderr).
    """
    from maopg.env import make_env
    from maopg.env.rollout import REFERENCE_POLICIES, reference_policy

    results = []
    for study_task in tasks:
        for strategy in strategies:
            env = make_env(study_task.task, strategy, seed=0, overrides=study_task.settings)
            try:
                for name in REFERENCE_POLICIES:
                    policy = reference_policy(name, env)
                    result = evaluate(env, policy, episodes, label=name, progress=progress)
                    results.append(result.summary)
            finally:
                env.close()
    return results


def reference_lines(
    runs: Sequence[RunData], episodes: int, *, progress: bool = False
) -> tuple[dict[str, dict[str, float]], list[str]]:
    """``(lines, notes)``: each task's scripted and random mean return over ``episodes``
    (strategy ``continue``, as in every study's figures) at its runs' task settings, the
    levels ``python -m eval plot`` draws. A task whose runs differ in their task settings has
    no single level to draw: it gets none, and a note naming the settings."""
    lines: dict[str, dict[str, float]] = {}
    notes: list[str] = []
    for task in sorted({r.task for r in runs}):
        settings = [task_settings(r) for r in runs if r.task == task]
        differ = differing_settings([{f"env.{k}": v for k, v in s.items()} for s in settings])
        if differ:
            differ_text = ", ".join(differ)
            notes.append(f"{task}: no reference lines, its runs differ in {differ_text}")
            continue
        study_task = StudyTask(task, (), settings[0])
        summaries = reference_results([study_task], episodes, ("continue",), progress=progress)
        lines[task] = {s["label"]: s["return_mean"] for s in summaries}
    return lines, notes


def policy_results(trained: Trained, run: RunData, episodes: int) -> list[dict]:
    """A run's final policy, greedy and sampled, over the same seeded episodes."""
    env = trained.make_env(0)
    results = []
    try:
        for greedy in (True, False):
            label = f"{run.method} seed{run.seed} {'greedy' if greedy else 'sampled'}"
            actor = trained.actor(greedy=greedy, seed=0)
            results.append(evaluate(env, actor, episodes, label=label).summary)
    finally:
        env.close()
    return results


def study_references(
    study: Study, tasks: Sequence[str], results_dir: str | Path, episodes: int
) -> list[dict]:
    """:func:`reference_results` of the study's ``tasks``, cached in ``reference.json``."""
    chosen = [study.task(t) for t in sorted(tasks)]
    key: dict = {"episodes": episodes, **behaviour([t.task for t in chosen])}
    if any(t.settings for t in chosen):
        key["settings"] = {t.task: dict(t.settings) for t in chosen}
    return cached(
        Path(results_dir) / "reference.json", key, lambda: reference_results(chosen, episodes)
    )


def normalising_levels(reference: Sequence[dict]) -> dict[str, tuple[float, float]]:
    """Each task's ``(random, scripted)`` mean return under ``continue`` (the strategy of the
    asynchronous methods; one pair per task so every method is scored on the same scale)."""
    levels = {
        (r["task"], r["label"]): r["return_mean"] for r in reference if r["strategy"] == "continue"
    }
    tasks = {task for task, _ in levels}
    return {t: (levels[t, "random"], levels[t, "scripted"]) for t in sorted(tasks)}


def reference_levels(task: StudyTask, path: Path, episodes: int) -> tuple[float, float]:
    """The ``(random, scripted)`` mean returns under ``continue`` of one task at its settings
    over ``episodes`` each (the scale of a normalised score), cached in ``path``."""
    key: dict = {"episodes": episodes, **behaviour([task.task]), "settings": dict(task.settings)}
    path.parent.mkdir(parents=True, exist_ok=True)
    summaries = cached(path, key, lambda: reference_results([task], episodes, ("continue",)))
    return normalising_levels(summaries)[task.task]


def write_evaluation(
    runs: Sequence[RunData], results_dir: str | Path, reference: list[dict], *, episodes: int = 10
) -> Path:
    """``evaluation.md``: the ``reference`` policies (:func:`study_references`) and
    :func:`policy_results` of every seed-0 run that kept its weights (cached in the run
    directory's ``evaluation.json``)."""
    from maopg.experiment.evaluation.loading import load_trained

    out = Path(results_dir)
    summaries: list[dict] = []
    for run in runs:
        if run.seed == 0 and (run.path / FINAL).exists():
            trained = load_trained(run.path / FINAL)
            key = weights_key(episodes, run.task, type(trained.policy), run.path / FINAL)
            summaries += cached(
                run.path / EVALUATION,
                key,
                lambda trained=trained, run=run: policy_results(trained, run, episodes),
            )
    text = (
        "# Evaluation\n\nGenerated by `python -m eval reproduce`: each policy plays seeded "
        "episodes (reset seeds 0, 1, ...; mean ± std over episodes).\n\n"
        "## Reference policies\n\n"
        "A random policy's return varies a lot from episode to episode, hence more episodes.\n\n"
        + results_table(reference)
        + "\n## Trained policies (seed 0 of each method, after training)\n\n"
        "Greedy takes the mode of the policy (Mac-DQN: ε = 0); sampled draws from it as in "
        "training (Mac-DQN: ε-greedy at its final ε).\n\n" + results_table(summaries)
    )
    path = out / "evaluation.md"
    path.write_text(text)
    return path


def baseline_runs(study: Study, root: str | Path | None = None) -> list[RunData]:
    """The finished runs of the study's ``baselines`` on its tasks, from the paper's run root
    (``root``, default ``results/runs``); none when it is absent (a fresh clone keeps them)."""
    root = Path(root) if root is not None else get_study(PAPER).runs_dir()
    if not root.exists():
        return []
    tasks = {t.task for t in study.tasks}
    return [r for r in discover_runs([root]) if r.task in tasks and r.method in study.baselines]


def reproduce(
    runs_root: str | Path,
    results_dir: str | Path,
    *,
    study: Study | str = PAPER,
    thresholds: Mapping[str, float] | None = None,
    window: int = 5,
    train: bool = True,
    eval_episodes: int = 10,
    reference_episodes: int = 100,
    baseline_root: str | Path | None = None,
    **grid_kw,
) -> tuple[dict[Cell, str], list[Path]]:
    """Run (or resume) the study's grid, then regenerate the results from the finished runs
    under ``runs_root`` (``eval_episodes=0`` skips ``evaluation.md``; ``reference_episodes``
    are the reference policies' episodes in it and in a normalised study's scores;
    ``baseline_root``: where the paper's runs are, default its run root; ``thresholds``: the
    user's, over the study's own). A ``dry_run``
    (of :func:`run_grid`) only lists what would run: it writes nothing. Where other processes
    still train some cells (:data:`BUSY`), the results wait for the one that ends last."""
    study = get_study(study) if isinstance(study, str) else study
    outcomes = run_grid(runs_root, study=study, **grid_kw) if train else {}
    if grid_kw.get("dry_run"):
        return outcomes, []
    root = Path(runs_root).resolve()
    busy = [c for c, o in outcomes.items() if o == BUSY and held_elsewhere(c.run_dir(root))]
    if busy:  # the invocation that ends last redraws the results
        grid_kw.get("log", print)(
            f"results not redrawn: {len(busy)} cell(s) still training in other processes"
        )
        return outcomes, []
    runs = discover_runs([runs_root]) if Path(runs_root).exists() else []
    if study.baselines:
        runs += baseline_runs(study, baseline_root)
    Path(results_dir).mkdir(parents=True, exist_ok=True)
    tasks = {r.task for r in runs}
    reference = []
    if runs and (eval_episodes > 0 or study.normalised):
        reference = study_references(study, tasks, results_dir, reference_episodes)
    written = write_results(
        runs,
        results_dir,
        thresholds={**study.thresholds(), **(thresholds or {})},
        window=window,
        references=normalising_levels(reference),
        normalised=study.normalised,
        published=study.published,
    )
    if eval_episodes > 0 and runs:
        written.append(write_evaluation(runs, results_dir, reference, episodes=eval_episodes))
    return outcomes, written

"""The reproduction grid: methods × tasks × seeds, resumable across sessions, then results.

Each cell is one training run in ``<runs>/<task>/<method>/seed<seed>``:

- **finished** (``done.json`` exists, written by the trainer at the very end): skipped;
- **partial** (a ``config.json`` but no ``done.json``: a run killed mid-way): resumed with
  ``--resume``, which continues from its last checkpoint bit for bit — or, where the checkpoint
  is gone (a fresh clone of the repository keeps no checkpoints), starts again;
- **new**: started.

The grid's default seeds and a few cells' settings of their own (the Water Filling Mac-DQN
replay size) are declared by each task at registration (``grid_seeds``, ``grid_overrides``), so
the one command reproduces exactly the committed grid; the methods are the registry's (those
it marks ``in_grid``).

Runs are launched as train command-line subprocesses (a crash or an out-of-memory kill loses
one run, not the grid), one after another or ``jobs`` at a time, or, with ``in_process=True``,
by calling the train command line in this process (faster to start; used by the tests). A
cell's run directory is locked while it trains (:mod:`maopg.experiment.run_lock`), so several
invocations over one grid share its cells out, and one that ends with no cell held elsewhere
redraws the results.
An unknown task or method is an error before anything runs (a typo must not pass as an empty
grid), and so is a bad override. ``overrides`` (``key=value`` train settings, as on the train
command line) and a ``config_file`` apply to every run and must be the same on every invocation
of a grid, because a resumed run refuses a config that differs from its saved one. Grid runs
record no rollout video (``video=false``; ``python -m eval video`` makes one from any finished
run).

Afterwards every figure and table is regenerated from the finished runs under ``<runs>`` into
``<results>``: per-task learning curves (all methods, and the Fig. 4 methods), their CSV,
``tables.md`` (peak, final, samples to threshold, Table I and II analogs) and
``evaluation.md``, the reference policies and every method's seed-0 policy evaluated over seeded
episodes (the levels the curves are read against, and greedy vs sampled action choice).
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from maopg.experiment.evaluate import evaluate, results_table
from maopg.experiment.methods import method_names
from maopg.experiment.plots import curve_table, plot_task
from maopg.experiment.run_dir import CONFIG, DONE, FINAL
from maopg.experiment.run_lock import RunDirBusy, RunDirLock, child_environment, held_elsewhere
from maopg.experiment.runs import RunData, differing_settings, discover_runs, task_settings
from maopg.experiment.studies import PAPER, Study, StudyTask, get_study
from maopg.experiment.tables import normalised_table, peak_table, threshold_table
from maopg.sim.assets import ASSETS_DIR

PACKAGE = Path(__file__).resolve().parents[1]
"""The ``maopg`` package (installed or cloned) whose code the evaluation cache is keyed on."""
REFERENCE_STRATEGIES = ("continue", "any", "all")
EVALUATION = "evaluation.json"
"""A seed-0 run's cached entry of ``evaluation.md``."""
FIG4_METHODS = ("async", "sync-cut", "sync-wait", "end2end")
TABLE1_METHODS = ("async", "mac-dqn")
TABLE2_METHODS = ("async", "partial")


@dataclass(frozen=True)
class Cell:
    task: str
    method: str
    seed: int

    def run_dir(self, runs_root: Path) -> Path:
        return runs_root / self.task / self.method / f"seed{self.seed}"


def cell_state(run_dir: Path) -> str:
    """``finished`` | ``partial`` | ``new`` (see the module docstring)."""
    if (run_dir / DONE).exists():
        return "finished"
    if (run_dir / CONFIG).exists():
        return "partial"
    return "new"


def check_cells(
    cells: Sequence[Cell],
    runs_root: Path,
    study: Study,
    overrides: Sequence[str],
    config_file: Path | None,
) -> None:
    """Read each task and method's train command line as the cell would, before any cell runs
    (``ValueError`` naming the cell and the setting): a bad override or config file must not
    fail every cell one after another."""
    from maopg.experiment.train_cli import parse_args

    for cell in {(c.task, c.method): c for c in cells}.values():
        args = _train_args(cell, cell.run_dir(runs_root), study, overrides, config_file)
        try:
            parse_args(args)[0].resolved()
        except ValueError as err:
            raise ValueError(
                f"{cell.task}/{cell.method}: {err} (settings go to every cell)"
            ) from None


def _train_args(
    cell: Cell,
    run_dir: Path,
    study: Study,
    overrides: Sequence[str],
    config_file: Path | None = None,
) -> list[str]:
    """The cell's train command line: ``--resume`` for a partial run (on a new one it is an
    error, which catches a mistyped directory)."""
    resume = ["--resume"] if cell_state(run_dir) == "partial" else []
    config = ["--config", str(config_file)] if config_file is not None else []
    return [
        *config,
        "--task",
        cell.task,
        "--method",
        cell.method,
        "--seed",
        str(cell.seed),
        "--run-dir",
        str(run_dir),
        *resume,
        "progress=false",
        "video=false",
        "eval_episodes=0",
        *study.overrides,
        *study.task(cell.task).train_args(cell.method),
        *overrides,
    ]


BUSY = "busy: another process is training it"
"""The outcome of a cell whose run directory another process holds (maopg.experiment.run_lock)."""


def _train_in_process(args: list[str]) -> str:
    """Train one cell by calling the train command line here; ``done`` or ``failed: <why>``."""
    from maopg.experiment.train_cli import main as train_main

    try:
        status = train_main(args)
    except (Exception, SystemExit) as err:  # one broken run must not stop the grid
        return f"failed: {type(err).__name__}: {err}"
    return "done" if status == 0 else f"failed: exit status {status}"


class _Launched:
    """A cell training in a train subprocess that inherits the cell's lock."""

    def __init__(self, name: str, args: list[str], lock: RunDirLock) -> None:
        self.name, self.lock = name, lock
        env, fds = child_environment(lock)
        command = [sys.executable, "-m", "maopg.experiment.train_cli", *args]
        try:
            self.proc = subprocess.Popen(command, env=env, pass_fds=fds)
        except BaseException:
            lock.release()
            raise

    def outcome(self) -> str:
        """Wait for the subprocess, then let the cell go."""
        code = self.proc.wait()
        self.lock.release()
        return "done" if code == 0 else f"failed: exit code {code}"

    def stop(self) -> None:
        """End the training now (the grid stops: an interrupt, an error); a killed run resumes
        from its last checkpoint."""
        self.proc.kill()
        self.proc.wait()
        self.lock.release()


def run_grid(
    runs_root: str | Path,
    *,
    study: Study | str = PAPER,
    tasks: Sequence[str] | None = None,
    methods: Sequence[str] | None = None,
    seeds: Sequence[int] | None = None,
    overrides: Sequence[str] = (),
    config_file: str | Path | None = None,
    in_process: bool = False,
    jobs: int = 1,
    dry_run: bool = False,
    log=print,
) -> dict[Cell, str]:
    """Bring every cell of the grid to ``finished``; returns each cell's outcome:
    ``skipped`` (already finished), ``done``, ``failed: ...``, :data:`BUSY` (another process
    trains it) or, with ``dry_run``, ``would start`` / ``would resume``. ``tasks`` and
    ``methods`` default to the study's (the ``paper`` study: every registered task, the grid's
    methods, :func:`~maopg.experiment.methods.grid_method_names`), ``seeds`` replaces every
    task's seeds; ``overrides`` (``key=value``) and ``config_file`` (a YAML or JSON settings
    file) go to every cell's train command line. ``jobs``: how many cells train at once, each in
    its own subprocess (each with its own environments and workers: ``jobs`` times the cores of
    one run). Raises ``ValueError`` for a task or method that is not registered or not part of
    the study, or a bad override.

    Each cell's run directory is locked before its training starts and until it ends, so
    several invocations over the same grid on one machine share out its cells: each skips the
    cells another holds (the lock is one machine's, :mod:`maopg.experiment.run_lock`)."""
    if jobs < 1:
        raise ValueError(f"jobs must be at least 1, got {jobs}")
    if jobs > 1 and in_process:
        raise ValueError("jobs > 1 trains cells in subprocesses; drop --in-process")
    study = get_study(study) if isinstance(study, str) else study
    tasks = list(tasks) if tasks is not None else [t.task for t in study.tasks]
    methods = list(methods) if methods is not None else list(study.methods)
    for kind, given, known in (
        ("task", tasks, [t.task for t in study.tasks]),
        ("method", methods, method_names()),
    ):
        unknown = [x for x in given if x not in known]
        if unknown:
            what = f"{kind}(s) {unknown} not in study {study.name!r}" if kind == "task" else ""
            raise ValueError(f"{what or f'unknown {kind}(s) {unknown}'}; choose from {known}")
    config_file = Path(config_file).resolve() if config_file is not None else None
    runs_root = Path(runs_root).resolve()
    outcomes: dict[Cell, str] = {}
    # Seed-major: an interrupted grid has every method at the same number of seeds.
    cells = [
        Cell(t, m, s)
        for t in tasks
        for s in (seeds if seeds is not None else study.task(t).seeds)
        for m in methods
    ]
    check_cells(cells, runs_root, study, overrides, config_file)
    running: dict[Cell, _Launched] = {}

    def settle(block: bool) -> None:
        """Record the cells whose training has ended (with ``block``, wait for one first)."""
        while True:
            ended = [c for c, job in running.items() if job.proc.poll() is not None]
            if ended or not block or not running:
                break
            time.sleep(0.5)
        for cell in ended:
            job = running.pop(cell)
            outcomes[cell] = job.outcome()
            log(f"{job.name}: {outcomes[cell]}")

    try:
        for k, cell in enumerate(cells, 1):
            run_dir = cell.run_dir(runs_root)
            name = f"[{k}/{len(cells)}] {cell.task}/{cell.method}/seed{cell.seed}"
            if not (dry_run or in_process):
                while len(running) >= jobs:  # the cell's state is read once a job is free
                    settle(block=True)
            if cell_state(run_dir) == "finished":
                outcomes[cell] = "skipped"
            elif dry_run or in_process:
                if held_elsewhere(run_dir):
                    outcomes[cell] = BUSY
                elif dry_run:
                    partial = cell_state(run_dir) == "partial"
                    outcomes[cell] = "would resume" if partial else "would start"
                else:  # train takes the lock itself, in this process
                    log(f"{name}: {_starting(run_dir)} in {run_dir}")
                    args = _train_args(cell, run_dir, study, overrides, config_file)
                    outcomes[cell] = _train_in_process(args)
            else:
                run_dir.mkdir(parents=True, exist_ok=True)
                lock = RunDirLock(run_dir)
                try:
                    lock.acquire()
                except RunDirBusy:  # another invocation trains it
                    outcomes[cell] = BUSY
                else:
                    if cell_state(run_dir) == "finished":  # ... or finished it just now
                        lock.release()
                        outcomes[cell] = "skipped"
                    else:
                        log(f"{name}: {_starting(run_dir)} in {run_dir}")
                        args = _train_args(cell, run_dir, study, overrides, config_file)
                        running[cell] = _Launched(name, args, lock)
                        settle(block=False)
                        continue
            log(f"{name}: {outcomes[cell]}")
        while running:
            settle(block=True)
    finally:  # an interrupt or an error: no training outlives the grid that started it
        for job in running.values():
            job.stop()
    return {cell: outcomes[cell] for cell in cells}


def _starting(run_dir: Path) -> str:
    return "resuming" if cell_state(run_dir) == "partial" else "starting"


def log_to_stderr(message: str) -> None:
    """A ``log`` for :func:`run_grid` that keeps stdout free (for scripts printing a report)."""
    print(message, file=sys.stderr)


def write_results(
    runs: Sequence[RunData],
    results_dir: str | Path,
    *,
    thresholds: Mapping[str, float] | None = None,
    window: int = 5,
    references: Mapping[str, tuple[float, float]] | None = None,
    normalised: bool = False,
) -> list[Path]:
    """Regenerate every figure, curve CSV and table of ``runs`` into ``results_dir``
    (``references``: each task's random and scripted return, drawn as reference lines and,
    in a ``normalised`` study, its scores' scale)."""
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


def _sha256(paths: Sequence[Path], root: Path, parts: Sequence[str] = ()) -> str:
    """sha256 over ``paths`` (named relative to ``root``, then their bytes) and ``parts``."""
    digest = hashlib.sha256()
    for path in paths:
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    for part in parts:
        digest.update(part.encode())
    return digest.hexdigest()


def code_digest() -> str:
    """sha256 of everything an evaluation's numbers depend on besides the weights: the
    simulator, tasks, policies and reference policies (``maopg/``), the robot and scene models
    (``assets/``) and the evaluation's own modules. Any change invalidates cached evaluations,
    so ``evaluation.md`` always describes the code it is committed with."""
    code = sorted(PACKAGE.rglob("*.py"))
    assets = sorted(p for p in ASSETS_DIR.rglob("*") if p.is_file())
    return _sha256([], PACKAGE, [_sha256(code, PACKAGE), _sha256(assets, ASSETS_DIR)])


def _cached(path: Path, key: dict, compute: Callable[[], list[dict]]) -> list[dict]:
    """Evaluation summaries stored in ``path`` if they were made for ``key`` (episodes, the
    code's and, for a trained policy, the weights' sha256), else computed and stored: the
    evaluations are deterministic and, on Water Filling, take minutes, so a rerun of the results
    only evaluates what is new or changed (delete the file to redo)."""
    if path.exists():
        saved = json.loads(path.read_text())
        if saved["key"] == key:
            return saved["results"]
    results = compute()
    path.write_text(json.dumps({"key": key, "results": results}, indent=2) + "\n")
    return results


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


def policy_results(run: RunData, episodes: int) -> list[dict]:
    """A run's final policy (``final.pt``), greedy and sampled, over the same seeded episodes."""
    from maopg.experiment.loading import load_trained

    trained = load_trained(run.path / FINAL)
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
    key: dict = {"episodes": episodes, "tasks": [t.task for t in chosen], "code": code_digest()}
    if any(t.settings for t in chosen):  # the paper's key stays as it was
        key["settings"] = {t.task: dict(t.settings) for t in chosen}
    return _cached(
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


def write_evaluation(
    runs: Sequence[RunData], results_dir: str | Path, reference: list[dict], *, episodes: int = 10
) -> Path:
    """``evaluation.md``: the ``reference`` policies (:func:`study_references`) and
    :func:`policy_results` of every seed-0 run that kept its weights (cached in the run
    directory's ``evaluation.json``)."""
    out = Path(results_dir)
    code = code_digest()
    trained: list[dict] = []
    for run in runs:
        if run.seed == 0 and (run.path / FINAL).exists():
            weights = _sha256([run.path / FINAL], run.path)
            trained += _cached(
                run.path / EVALUATION,
                {"episodes": episodes, "code": code, "weights": weights},
                lambda run=run: policy_results(run, episodes),
            )
    text = (
        "# Evaluation\n\nGenerated by `python -m eval reproduce`: each policy plays seeded "
        "episodes (reset seeds 0, 1, ...; mean ± std over episodes).\n\n"
        "## Reference policies\n\n"
        "A random policy's return varies a lot from episode to episode, hence more episodes.\n\n"
        + results_table(reference)
        + "\n## Trained policies (seed 0 of each method, after training)\n\n"
        "Greedy takes the mode of the policy (Mac-DQN: ε = 0); sampled draws from it as in "
        "training (Mac-DQN: ε-greedy at its final ε).\n\n" + results_table(trained)
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
    ``baseline_root``: where the paper's runs are, default its run root). A ``dry_run``
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
        thresholds=thresholds,
        window=window,
        references=normalising_levels(reference),
        normalised=study.normalised,
    )
    if eval_episodes > 0 and runs:
        written.append(write_evaluation(runs, results_dir, reference, episodes=eval_episodes))
    return outcomes, written

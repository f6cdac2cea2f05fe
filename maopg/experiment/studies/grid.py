"""The reproduction grid: a study's methods × tasks × seeds, resumable across sessions.

Each cell is one training run in ``<runs>/<task>/<method>/seed<seed>``:

- **finished** (``done.json`` exists, written by the trainer at the very end): skipped;
- **partial** (a ``config.json`` but no ``done.json``: a run killed mid-way): resumed, which
  continues from its last checkpoint bit for bit — or, where the checkpoint is gone (a fresh
  clone of the repository keeps no checkpoints), starts again;
- **new**: started.

The grid builds each cell's :class:`~maopg.experiment.run.config.TrainConfig` from the study's
typed settings (:func:`cell_config`) and calls the training function with it: in this process
(``in_process=True``; the tests), or in a subprocess per cell, one after another or ``jobs`` at
a time, so a crash or an out-of-memory kill loses one run, not the grid. A cell's run directory
is locked while it trains (:mod:`maopg.experiment.run.lock`), so several invocations over one
grid share its cells out.

An unknown task or method is an error before anything runs (a typo must not pass as an empty
grid), and so is a bad override. ``overrides`` (``key=value`` train settings, as on the train
command line) and a ``config_file`` apply to every run and must be the same on every invocation
of a grid, because a resumed run refuses a config that differs from its saved one. Grid runs
record no rollout video (``python -m eval video`` makes one from any finished run).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from maopg.experiment.run.config import (
    TrainConfig,
    merge,
    nest_settings,
    parse_overrides,
    unset_run,
)
from maopg.experiment.run.config_file import read_config_file
from maopg.experiment.run.directory import CONFIG, DONE
from maopg.experiment.run.lock import RunDirBusy, RunDirLock, child_environment, held_elsewhere
from maopg.experiment.run.methods import method_names
from maopg.experiment.studies.registry import PAPER, Study, get_study
from maopg.plugins import load_plugins

GRID_SETTINGS = {"progress": False, "video": False, "eval_episodes": 0}
"""What every grid run leaves out: a progress bar, the rollout video, the evaluation after
training (the results' own evaluation reads the seed-0 policies)."""


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


def cell_config(
    cell: Cell,
    runs_root: Path,
    study: Study,
    overrides: Sequence[str] = (),
    config_file: Path | None = None,
) -> tuple[TrainConfig, bool]:
    """The cell's training config and whether it resumes (a partial run), built as ``train``
    builds a run's: the defaults (a partial run: its saved config), then ``config_file``, then
    the grid's own settings (no progress bar, no video, no evaluation after training), the
    study's, the task's and the method's on that task, then the user's ``overrides``
    (``key=value``), then the cell's task, method, seed and run directory. The plugins of the
    config file and of a partial run are imported first: the cell's task or method may be
    theirs."""
    run_dir = cell.run_dir(runs_root)
    resume = cell_state(run_dir) == "partial"
    from_file = read_config_file(config_file) if config_file is not None else {}
    saved = read_config_file(run_dir / CONFIG) if resume else {}
    loaded = load_plugins([*from_file.get("plugins", []), *saved.get("plugins", [])])
    base = TrainConfig.from_dict(saved).to_dict() if resume else unset_run(cell.method)
    settings = {
        **GRID_SETTINGS,
        **study.overrides,
        **study.task(cell.task).train_settings(cell.method),
    }
    values = merge(
        nest_settings(settings, cell.method), parse_overrides(list(overrides), cell.method)
    )
    named = {"task": cell.task, "method": cell.method, "seed": cell.seed, "run_dir": str(run_dir)}
    for key, value in named.items():
        if key in values and values[key] != value:
            raise ValueError(f"{key}={values[key]} contradicts the grid's cell ({key} {value})")
    merged = {**merge(merge(base, from_file), values), **named}
    plugins = [*merged.get("plugins", []), *from_file.get("plugins", []), *loaded]
    merged["plugins"] = list(dict.fromkeys(plugins))
    return TrainConfig.from_dict(merged), resume


def check_cells(
    cells: Sequence[Cell],
    runs_root: Path,
    study: Study,
    overrides: Sequence[str],
    config_file: Path | None,
) -> None:
    """Build and resolve each task and method's config as its cells will, before any cell runs
    (``ValueError`` naming the cell and the setting): a bad override or config file must not
    fail every cell one after another."""
    for cell in {(c.task, c.method): c for c in cells}.values():
        try:
            cell_config(cell, runs_root, study, overrides, config_file)[0].resolved()
        except ValueError as err:
            raise ValueError(
                f"{cell.task}/{cell.method}: {err} (settings go to every cell)"
            ) from None


BUSY = "busy: another process is training it"
"""The outcome of a cell whose run directory another process holds (maopg.experiment.run.lock)."""


def _train_in_process(config: TrainConfig, resume: bool) -> str:
    """Train one cell in this process; ``done`` or ``failed: <why>``."""
    from maopg.experiment.training.trainer import train

    try:
        train(config, resume=resume)
    except Exception as err:  # one broken run must not stop the grid
        return f"failed: {type(err).__name__}: {err}"
    return "done"


class _Launched:
    """A cell training in a subprocess of its own (:mod:`maopg.experiment.studies.cell`) that
    inherits the cell's lock and reads the cell's config from its standard input."""

    def __init__(self, name: str, config: TrainConfig, resume: bool, lock: RunDirLock) -> None:
        self.name, self.lock = name, lock
        env, fds = child_environment(lock)
        command = [sys.executable, "-m", "maopg.experiment.studies.cell"]
        request = json.dumps({"config": config.to_dict(), "resume": resume})
        try:
            self.proc = subprocess.Popen(
                command, env=env, pass_fds=fds, stdin=subprocess.PIPE, text=True
            )
            assert self.proc.stdin is not None
            self.proc.stdin.write(request)
            self.proc.stdin.close()
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
    ``methods`` default to the study's, ``seeds`` replaces every task's seeds;
    ``overrides`` (``key=value``, as on the train command line) and ``config_file`` (a YAML or
    JSON settings file) go to every cell's config (:func:`cell_config`). ``jobs``: how many
    cells train at once, each in
    its own subprocess (each with its own environments and workers: ``jobs`` times the cores of
    one run). Raises ``ValueError`` for a task or method that is not registered or not part of
    the study, or a bad override.

    Each cell's run directory is locked before its training starts and until it ends, so
    several invocations over the same grid on one machine share out its cells: each skips the
    cells another holds (the lock is one machine's, :mod:`maopg.experiment.run.lock`)."""
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
                    config, resume = cell_config(cell, runs_root, study, overrides, config_file)
                    outcomes[cell] = _train_in_process(config, resume)
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
                        try:
                            config, resume = cell_config(
                                cell, runs_root, study, overrides, config_file
                            )
                        except BaseException:  # a partial run's unreadable config, say
                            lock.release()
                            raise
                        running[cell] = _Launched(name, config, resume, lock)
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

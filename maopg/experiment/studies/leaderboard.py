"""The leaderboard: every method on every task that supports it, read by one protocol and set
on one scale (``python -m eval reproduce --study leaderboard``; ``results/leaderboard/``).

A **board** is one task of a committed study at that study's settings, seeds, budget and
threshold (Tool Delivery of the ``paper`` study, the 6x6 grid of ``box-pushing-6``, the team of
eight of ``teams``, ...), and the methods ranked on it. A method's runs that a committed study
already has are read where they are — and trained there, by that study's own definition, while
they are missing — so a leaderboard cell is never a second copy of a study's cell; a method no
study runs on that task trains under ``results/leaderboard/runs/<board>/`` at the board's
settings plus its :attr:`Board.method_overrides`.

The protocol, the same for every method on a board: where the board's study evaluates the
policy during training (the Box Pushing boards: 10 episodes sampled without ε, every 2,000
samples), a run's **final return** is its value at the board's budget on maopg's counter —
the mean of its last 5 evaluations at or before it, as the published curves are read
(:func:`~maopg.experiment.studies.published.value_at`) — and its **samples to threshold** the
first evaluation, within the budget, where that trailing mean reaches the board's threshold.
Training episodes would not do there: they are ε-mixed on schedules that differ by method,
and ACAC's and MacroMARL's rounds log only the episodes that finish within a round (their
runs also train past the budget, for the published counter). Where the study logs no
evaluation (the paper's tasks and the teams of eight, whose committed runs keep no weights but
seed 0's), the final return is the mean training-episode return over the last 10 % of samples
(:func:`~maopg.experiment.studies.runs.final`, the figure of every study's tables) and the
samples to threshold the first iteration whose trailing mean over 5 logged iterations reaches
the threshold. Its **normalised score** is ``(R − R_random) / (R_scripted − R_random)`` against
the uniform-random and scripted policies measured at the board's settings (0: random, 1: the
scripted heuristic).

Per board: each method's budget, mean final return and normalised score with a percentile
bootstrap 95 % interval over its seeds, its samples to threshold over the seeds that reach it,
and every seed's outcome. Across boards: each method's interquartile mean of normalised scores
with a stratified bootstrap interval (every board's seeds resampled within the board) over the
boards it runs on; the paper's conditional policy against the literature's methods over the
boards all three share (:data:`HEADLINE`: the issue's question, asked on equal terms); and a
performance profile (the share of runs scoring above each τ): Agarwal et al., NeurIPS 2021.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from maopg.experiment.run.config import task_learner_defaults
from maopg.experiment.run.methods import get_method, method_names
from maopg.experiment.studies.builtin import (
    ACAC_COLLECTION,
    BOX_PUSHING_METHODS,
    FEW_EPISODES,
    PAPER_METHODS,
    macromarl,
)
from maopg.experiment.studies.grid import Cell, run_grid
from maopg.experiment.studies.option_usage import USAGE_EPISODES, option_usage, usage_table
from maopg.experiment.studies.published import EVAL_RETURN, LAST, value_at
from maopg.experiment.studies.registry import (
    LEADERBOARD,
    PAPER,
    Settings,
    Study,
    frozen,
    get_study,
)
from maopg.experiment.studies.results import reference_levels
from maopg.experiment.studies.runs import (
    RETURN,
    RunData,
    discover_runs,
    final,
    samples_to_threshold,
)
from maopg.experiment.studies.stats import (
    iqm,
    performance_profile,
    stratified_bootstrap_interval,
)
from maopg.experiment.studies.tables import markdown_table, mean_interval

THRESHOLD_WINDOW = 5
"""Logged iterations the samples-to-threshold curve is smoothed over (as every study's)."""
REFERENCE_EPISODES = 100
"""Episodes of each reference policy a board's normalising levels average."""
PROFILE_TAUS = np.linspace(-0.5, 1.5, 81)
"""The normalised scores τ of the performance profile."""
AGENT_METHODS = ("acac", "mac-iaicc")
"""The literature's asynchronous methods (issue 45): per-agent actors, so they run at any team
size."""
TEAM_METHODS = ("async-ar", "partial-ar", "sync-cut-ar")
"""The factored forms of the paper's methods that fit a team of eight (the product
categorical's 15.3M joint options do not: the ``teams`` study)."""

CONDITIONAL = ("async", "async-ar")
"""The paper's conditional centralized policy on a board: its product categorical (``async``)
where the board ranks it, else its autoregressive form (``async-ar``: the teams of eight, where
the product's head is refused)."""
HEADLINE = ("the paper's policy", "acac", "mac-iaicc")
"""The rows of the headline comparison: :data:`CONDITIONAL` against the literature's methods."""

TUNING: Mapping[str, str] = {
    **dict.fromkeys((*PAPER_METHODS, *TEAM_METHODS), "maopg defaults"),
    "async-rnn": "maopg defaults, memory study's GRU",
    "acac": "ACAC published (Box Pushing)",
    "mac-iaicc": "MacroMARL scripts (Box Pushing)",
}
"""How each method's settings were chosen, the label beside its rows (:data:`TUNING_NOTE`)
unless a board says otherwise (:attr:`Board.tuning`)."""
FEW_EPISODES_LABEL = "few-episode settings"
FEW_EPISODES_TUNING = frozen(dict.fromkeys(AGENT_METHODS, FEW_EPISODES_LABEL))
"""The label of :data:`~maopg.experiment.studies.builtin.FEW_EPISODES` beside its rows."""
EXPLORED = "the grid's exploration"
"""Added to the label of the methods that explore by the Box Pushing tasks' training defaults."""
TUNING_NOTE = (
    "Tuning: *maopg defaults* — one set of settings for every task, chosen on Tool Delivery and "
    "Water Filling in the paper's reproduction, no per-task tuning; *memory study's GRU* — "
    "those plus the option history and layer norm the memory study found the GRU needs; "
    f"*{EXPLORED}* — on Box Pushing, the tasks' training defaults: ε-mixed sampling over the "
    "joint option on ACAC's schedule, the best of the exploration pilots on the 6x6 grid "
    "(`bench/analysis/exploration_pilots.py`, docs/results/exploration.md); *ACAC "
    "published* — ACAC's published Box Pushing settings (box-pushing reference §10) with its "
    "32 environments and γ 0.98, no tuning here; *MacroMARL scripts* — Mac-IAICC's settings "
    "in MacroMARL's Box Pushing scripts (32 environments, γ 0.98, each size's target and ε "
    "schedule), no tuning here; *few-episode settings* — on the tasks whose budgets hold "
    "hundreds of episodes, not the tens of thousands those settings are made for: ACAC "
    "updated as maopg's PPO and Mac-IAICC as MacroMARL's Warehouse scripts, each with ε "
    "falling over 50 episodes, chosen by pilots on Tool Delivery "
    "(`bench/analysis/few_episode_pilots.py`, "
    "`maopg.experiment.studies.builtin.FEW_EPISODES`). Budget: the samples (maopg's counter: "
    "every simulated tick) a method's runs are read at; on Box Pushing every method is read "
    "at the board's budget, where ACAC's and MacroMARL's runs go on until their published "
    "counter (finished training episodes' ticks) passes it, for the Box Pushing studies' "
    "comparison with the published curves."
)
"""What each :data:`TUNING` label means."""


PILOTS = {
    FEW_EPISODES_LABEL: (Path("pilots"), ("tool_delivery",)),
    EXPLORED: (Path("../exploration/pilots"), ("box_pushing_grid",)),
}
"""Each piloted tuning label: where its pilots are logged, relative to the leaderboard's results
(``bench/analysis/few_episode_pilots.py``, ``bench/analysis/exploration_pilots.py``), and the
tasks of the pilots that chose it (the exploration pilots on Tool Delivery decided where not to
explore, which no row's label carries)."""


def pilot_budgets(results_dir: Path) -> str:
    """The tuning budget behind each piloted label, counted from the logged pilot runs (finished
    ones): per method, its pilots (settings tried), runs and samples trained, and the tasks they
    ran on; empty where no pilots are logged."""
    parts = []
    for label, (where, tasks) in PILOTS.items():
        root = results_dir / where
        if not root.exists():
            continue
        by_method: dict[str, list[RunData]] = {}
        for run in discover_runs([root]):
            if run.task in tasks:
                by_method.setdefault(run.method, []).append(run)
        counts = [
            f"`{method}` {_count(len({r.path.parent.name for r in runs}), 'pilot')}, "
            f"{_count(len(runs), 'run')}, {_samples(sum(float(r.samples[-1]) for r in runs))} "
            "samples on " + ", ".join(sorted({r.task for r in runs}))
            for method, runs in sorted(by_method.items())
        ]
        if counts:
            parts.append(f"*{label}* — {'; '.join(counts)}")
    if not parts:
        return ""
    return (
        " Tuning budgets, counted from the logged pilot runs (settings tried, runs, samples): "
        + "; ".join(parts)
        + "."
    )


@dataclass(frozen=True)
class Board:
    """One task of the leaderboard: ``task`` of the committed study ``study`` (its settings,
    seeds, budget and threshold) and the methods ranked on it."""

    name: str
    study: str
    task: str
    methods: tuple[str, ...]
    reuse: Mapping[str, str] = field(default_factory=frozen)
    """Method → another committed study whose runs of this same task it reads (the study's own
    methods are read from it without saying)."""
    method_overrides: Mapping[str, Settings] = field(default_factory=frozen)
    """Train settings of the methods trained here (those no committed study runs)."""
    tuning: Mapping[str, str] = field(default_factory=frozen)
    """Method → how its settings were chosen on this board, where not :data:`TUNING`'s."""

    def tuning_of(self, method: str) -> str:
        """The tuning label beside ``method``'s row (:data:`TUNING_NOTE`), with
        :data:`EXPLORED` where the task's training defaults set the method's exploration."""
        label = self.tuning.get(method, TUNING.get(method, "—"))
        if method in method_names() and any(
            key.startswith("explore")
            for key in task_learner_defaults(self.task, get_method(method).section)
        ):
            label += f", {EXPLORED}"
        return label

    def home(self, method: str) -> str | None:
        """The committed study whose runs hold ``method``'s cells, ``None`` for the
        leaderboard's own."""
        if method in self.reuse:
            return self.reuse[method]
        return self.study if method in get_study(self.study).methods else None

    def grids(self, root: Path) -> list[tuple[Study, Path, tuple[str, ...]]]:
        """``(study, run root, methods)`` of each grid that holds this board's cells: the
        committed studies' (their own definitions, their run roots) and, for the methods no
        study runs, this board's own study under ``root / name``."""
        homes: dict[str | None, list[str]] = {}
        for method in self.methods:
            homes.setdefault(self.home(method), []).append(method)
        grids = []
        for home, methods in homes.items():
            if home is not None:
                study = get_study(home)
                grids.append((study, study.runs_dir(), tuple(methods)))
                continue
            source = get_study(self.study)
            task = source.task(self.task)
            own = replace(task, method_overrides={**task.method_overrides, **self.method_overrides})
            study = Study(
                f"{LEADERBOARD}-{self.name}",
                f"{', '.join(methods)} on the {self.name} board",
                (own,),
                tuple(methods),
                overrides=source.overrides,
            )
            grids.append((study, root / self.name, tuple(methods)))
        return grids


def _boards() -> tuple[Board, ...]:
    """The leaderboard's boards (module docstring): the issue's tasks, each at its committed
    study's settings. In MuJoCo's Box Pushing ACAC and Mac-IAICC collect as on the grid (32
    environments, γ 0.98, Mac-IAICC's 6x6 targets, ε and state critics, the task reporting the
    grid's state read off its physics) within the study's budget; on the
    other tasks, whose budgets hold hundreds of episodes, they take their few-episode settings
    (:data:`~maopg.experiment.studies.builtin.FEW_EPISODES`)."""
    grid_methods = (*BOX_PUSHING_METHODS, *AGENT_METHODS)
    mujoco = {k: v for k, v in macromarl(6)["mac-iaicc"].items() if k != "total_samples"}
    few = {"method_overrides": FEW_EPISODES, "tuning": FEW_EPISODES_TUNING}
    return (
        Board(
            "tool_delivery",
            PAPER,
            "tool_delivery",
            (*PAPER_METHODS, "async-ar", *AGENT_METHODS),
            reuse=frozen({"async-ar": "chain-rule"}),
            **few,
        ),
        Board(
            "water_filling",
            PAPER,
            "water_filling",
            (*PAPER_METHODS, "async-rnn", *AGENT_METHODS),
            reuse=frozen({"async-rnn": "memory"}),
            **few,
        ),
        Board("box_pushing_grid_6", "box-pushing-6", "box_pushing_grid", grid_methods),
        Board("box_pushing_grid_10", "box-pushing-10", "box_pushing_grid", grid_methods),
        Board(
            "box_pushing",
            "box-pushing-mujoco",
            "box_pushing",
            grid_methods,
            method_overrides=frozen({"acac": ACAC_COLLECTION, "mac-iaicc": frozen(mujoco)}),
        ),
        Board(
            "tool_delivery_8_masked",
            "teams",
            "tool_delivery",
            (*TEAM_METHODS, *AGENT_METHODS),
            **few,
        ),
        Board(
            "tool_delivery_8",
            "teams-canonical",
            "tool_delivery",
            (*TEAM_METHODS, *AGENT_METHODS),
            **few,
        ),
        Board("water_filling_8", "teams", "water_filling", (*TEAM_METHODS, *AGENT_METHODS), **few),
    )


BOARDS = _boards()
"""The committed leaderboard."""


# ------------------------------------------------------------------------------- per run
@dataclass(frozen=True)
class Entry:
    """One run read by the leaderboard's protocol."""

    board: str
    method: str
    seed: int
    final_return: float
    score: float
    """Normalised final return (``nan`` where the board has no reference levels)."""
    to_threshold: float
    """Samples to the board's threshold (``nan``: never reached, or no threshold)."""
    finished: bool
    samples: float = math.nan
    """The samples the run was read at (maopg's counter): the samples it trained, or the
    board's budget where the board reads evaluations and the run trained past it."""


def board_runs(board: Board, root: Path) -> list[RunData]:
    """The logged runs of the board's methods on its task, wherever they live
    (:meth:`Board.grids`)."""
    found = []
    for _, runs_root, methods in board.grids(root):
        if runs_root.exists():
            found += [
                r
                for r in discover_runs([runs_root])
                if r.task == board.task and r.method in methods
            ]
    return found


def evaluated_budget(board: Board) -> float | None:
    """The board's budget (maopg's counter) where its study evaluates the policy during
    training (the Box Pushing boards), ``None`` where it does not."""
    study = get_study(board.study)
    if not dict(study.overrides).get("eval_every"):
        return None
    task = study.task(board.task)
    return float({**study.overrides, **task.overrides}["total_samples"])


def _read(run: RunData, threshold: float | None, budget: float | None) -> tuple[float, float]:
    """``(final return, samples to threshold)`` of one run by the protocol (module docstring):
    from its evaluations at the board's ``budget`` where the board has one, else from its
    training episodes. A run that has not reached the budget yet is read where it stands."""
    if budget is None:
        value = final(run, RETURN)
        reached = (
            samples_to_threshold(run, threshold, RETURN, THRESHOLD_WINDOW)
            if threshold is not None
            else math.nan
        )
        return value, reached
    last = float(run.samples[-1]) if run.samples.size else math.nan
    value = value_at(run, min(budget, last)) if run.samples.size else math.nan
    reached = (
        samples_to_threshold(run, threshold, EVAL_RETURN, LAST)
        if threshold is not None and EVAL_RETURN in run.metrics
        else math.nan
    )
    return value, reached if reached <= budget else math.nan


def entries(
    board: Board, runs: Sequence[RunData], levels: tuple[float, float] | None
) -> list[Entry]:
    """Each run of the board by the protocol (module docstring, :func:`_read`); ``levels``:
    the board's ``(random, scripted)`` mean returns."""
    threshold = get_study(board.study).task(board.task).threshold
    budget = evaluated_budget(board)
    out = []
    for run in runs:
        value, reached = _read(run, threshold, budget)
        score = math.nan if levels is None else (value - levels[0]) / (levels[1] - levels[0])
        samples = float(run.samples[-1]) if run.samples.size else math.nan
        if budget is not None:
            samples = min(samples, budget)
        out.append(
            Entry(board.name, run.method, run.seed, value, score, reached, run.finished, samples)
        )
    return out


def board_levels(board: Board, results_dir: Path, episodes: int) -> tuple[float, float]:
    """The board's ``(random, scripted)`` mean returns under ``continue`` at its settings,
    cached in ``<results>/references/<board>.json``."""
    task = get_study(board.study).task(board.task)
    return reference_levels(task, results_dir / "references" / f"{board.name}.json", episodes)


# ------------------------------------------------------------------------------- tables
def _large(value: float) -> str:
    return f"{value / 1000:.0f}K" if abs(value) >= 10_000 else f"{value:.1f}"


def _count(n: int, thing: str) -> str:
    """``1 pilot``, ``2 pilots``."""
    return f"{n} {thing}" if n == 1 else f"{n} {thing}s"


def _samples(value: float) -> str:
    """A count of samples in one unit whatever its size: ``8.0K``, ``39.4K``, ``1.20M``."""
    return f"{value / 1e6:.2f}M" if value >= 1e6 else f"{value / 1e3:.1f}K"


def _budget(entries: Sequence[Entry]) -> str:
    """The samples the method's runs trained: the finished runs' (the most of them)."""
    done = [e.samples for e in entries if e.finished] or [e.samples for e in entries]
    most = max(done)
    return f"{most / 1e6:.1f}M" if most >= 1e6 else f"{most / 1e3:.0f}K"


def board_table(board: Board, rows: Sequence[Entry]) -> str:
    """One board: per method its tuning, seeds, budget, final return and normalised score (mean
    and bootstrap 95 % interval), samples to threshold over the seeds that reach it, every
    seed."""
    table = []
    for method in board.methods:
        mine = sorted((e for e in rows if e.method == method), key=lambda e: e.seed)
        if not mine:
            table.append([method, board.tuning_of(method), "0", "—", "—", "—", "—", "not run yet"])
            continue
        running = sum(not e.finished for e in mine)
        seeds = f"{len(mine)}" + (f" ({running} running)" if running else "")
        reached = [e.to_threshold for e in mine if not math.isnan(e.to_threshold)]
        threshold = mean_interval(reached, _samples) + f" ({len(reached)} of {len(mine)})"
        each = ", ".join(
            f"seed{e.seed} {_large(e.final_return)}{' ✓' if not math.isnan(e.to_threshold) else ''}"
            for e in mine
        )
        table.append(
            [
                method,
                board.tuning_of(method),
                seeds,
                _budget(mine),
                mean_interval([e.final_return for e in mine], "{:.1f}".format),
                mean_interval([e.score for e in mine], "{:.2f}".format),
                threshold,
                each,
            ]
        )
    header = [
        "method",
        "tuning",
        "seeds",
        "budget",
        "final return [95 % CI]",
        "normalised [95 % CI]",
        "samples to threshold [95 % CI] (seeds)",
        "each seed: final return (✓ reached the threshold)",
    ]
    return markdown_table(header, table)


def _interval(scores: Sequence[np.ndarray]) -> str:
    """The IQM of per-board score arrays with its stratified bootstrap 95 % interval."""
    low, high = stratified_bootstrap_interval(scores)
    return f"{iqm(np.concatenate(scores)):.2f} [{low:.2f}, {high:.2f}]"


def _finished_scores(rows: Sequence[Entry]) -> list[Entry]:
    """The entries of finished runs with a score: what the comparisons across boards read (a
    run still training stands only in its board's table, marked running)."""
    return [e for e in rows if e.finished and not math.isnan(e.score)]


def _scores(rows: Sequence[Entry], board: str, method: str | None) -> np.ndarray:
    return np.array(
        [e.score for e in _finished_scores(rows) if e.board == board and e.method == method]
    )


def aggregate_table(boards: Sequence[Board], rows: Sequence[Entry]) -> str:
    """Per method: the interquartile mean of its normalised scores with a stratified bootstrap
    95 % interval over every board it has runs on (methods on other boards: not a comparison
    on equal terms; :func:`headline_table` is one)."""
    table = []
    for method in dict.fromkeys(m for b in boards for m in b.methods):
        scores = [got for b in boards if (got := _scores(rows, b.name, method)).size]
        if scores:
            table.append([method, str(len(scores)), _interval(scores)])
    return markdown_table(["method", "boards", "IQM normalised, its boards [95 % CI]"], table)


def _method_on(board: Board, row: str) -> str | None:
    """The method that stands for headline ``row`` on ``board`` (the paper's policy:
    :data:`CONDITIONAL`'s first that the board ranks), ``None`` where it has none."""
    if row != HEADLINE[0]:
        return row if row in board.methods else None
    return next((m for m in CONDITIONAL if m in board.methods), None)


def shared_boards(boards: Sequence[Board], rows: Sequence[Entry]) -> list[Board]:
    """The boards where every :data:`HEADLINE` row has runs."""
    return [
        b for b in boards if all(_scores(rows, b.name, _method_on(b, r)).size for r in HEADLINE)
    ]


def headline_table(boards: Sequence[Board], rows: Sequence[Entry]) -> str:
    """The paper's conditional centralized policy (:data:`CONDITIONAL`: ``async``, or
    ``async-ar`` where a board does not rank the product) against ACAC and Mac-IAICC on the
    boards where all three have runs: the IQM of normalised scores with a stratified bootstrap
    95 % interval, and each board's mean score."""
    scores = {
        row: {
            b.name: (_method_on(b, row), _scores(rows, b.name, _method_on(b, row))) for b in boards
        }
        for row in HEADLINE
    }
    shared = [b.name for b in shared_boards(boards, rows)]
    table = []
    for row in HEADLINE:
        cells = [row, _interval([scores[row][b][1] for b in shared]) if shared else "—"]
        for board in shared:
            method, got = scores[row][board]
            cells.append(f"{got.mean():.2f}" + (f" (`{method}`)" if row == HEADLINE[0] else ""))
        table.append(cells)
    counted = f"the {len(shared)} boards" if len(shared) != 1 else "the board"
    header = ["", f"IQM normalised, {counted} all three share [95 % CI]", *shared]
    missing = [b.name for b in boards if b.name not in shared]
    note = f"\nBoards where one of the three has no runs yet: {', '.join(missing) or 'none'}.\n"
    return markdown_table(header, table) + note


def headline_usage(
    board: Board, runs: Sequence[RunData], episodes: int, rows: Sequence[Entry]
) -> list[tuple[str, str, dict, float]]:
    """``(board, method, usage, read)`` of the headline methods' seed-0 runs on ``board`` that
    kept their weights (:func:`~maopg.experiment.studies.option_usage.option_usage`); ``read``:
    the same run's final return as the board reads it, from its entry among ``rows`` (``nan``
    where it has none)."""
    found = []
    for row in HEADLINE:
        method = _method_on(board, row)
        run = next((r for r in runs if r.method == method and r.seed == 0 and r.finished), None)
        usage = option_usage(run, episodes) if run is not None else None
        if usage is not None:
            read = next(
                (
                    e.final_return
                    for e in rows
                    if (e.board, e.method, e.seed) == (board.name, method, 0)
                ),
                math.nan,
            )
            found.append((board.name, method, usage, read))
    return found


def plot_profile(rows: Sequence[Entry], out_stem: Path) -> list[Path]:
    """The performance profile (the share of each method's runs, pooled over its boards, whose
    normalised score exceeds τ) as ``<out_stem>.png`` and ``.svg``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2))
    for method in dict.fromkeys(e.method for e in rows):
        scores = np.array([e.score for e in _finished_scores(rows) if e.method == method])
        if scores.size:
            profile = performance_profile(scores, PROFILE_TAUS)
            ax.plot(PROFILE_TAUS, profile, label=f"{method} ({scores.size} runs)")
    ax.set_xlabel("normalised score τ (0: random, 1: scripted)")
    ax.set_ylabel("fraction of runs with score > τ")
    ax.set_title("Performance profile over the leaderboard's boards", fontsize=11)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=7)
    fig.tight_layout()
    paths = []
    with plt.rc_context({"svg.hashsalt": "maopg"}):  # the same runs redraw identical files
        for suffix, metadata in ((".png", {"Software": None}), (".svg", {"Date": None})):
            paths.append(out_stem.with_suffix(suffix))
            fig.savefig(paths[-1], dpi=130, metadata=metadata)
    plt.close(fig)
    return paths


# ------------------------------------------------------------------------------- reproduce
def reproduce_leaderboard(
    results_dir: str | Path = Path("results", LEADERBOARD),
    *,
    boards: Sequence[Board] = BOARDS,
    methods: Sequence[str] | None = None,
    train: bool = True,
    reference_episodes: int = REFERENCE_EPISODES,
    usage_episodes: int = USAGE_EPISODES,
    log: Callable[[str], None] = print,
    **grid_kw,
) -> tuple[dict[tuple[str, Cell], str], list[Path]]:
    """Bring every board's cells to finished (each in the grid that holds it: a committed
    study's own, or ``<results>/runs/<board>``), then write ``tables.md``, ``scores.csv`` and
    the performance profile from the logged runs. Returns each cell's outcome (by board) and
    the files written. ``methods``: only these (all boards' by default); ``grid_kw``:
    :func:`~maopg.experiment.studies.grid.run_grid`'s ``jobs``, ``dry_run``, ``in_process``, ...
    A ``dry_run`` writes nothing."""
    out = Path(results_dir)
    chosen = [
        replace(b, methods=tuple(m for m in b.methods if methods is None or m in methods))
        for b in boards
    ]
    outcomes: dict[tuple[str, Cell], str] = {}
    for board in chosen if train else ():
        for study, runs_root, board_methods in board.grids(out / "runs"):
            log(f"{board.name}: {', '.join(board_methods)} in {runs_root}")
            done = run_grid(
                runs_root,
                study=study,
                tasks=[board.task],
                methods=board_methods,
                log=log,
                **grid_kw,
            )
            outcomes.update({(board.name, cell): outcome for cell, outcome in done.items()})
    if grid_kw.get("dry_run"):
        return outcomes, []
    out.mkdir(parents=True, exist_ok=True)
    rows: list[Entry] = []
    sections = []
    runs_of: dict[str, list[RunData]] = {}
    for board in chosen:
        runs = runs_of[board.name] = board_runs(board, out / "runs")
        levels = board_levels(board, out, reference_episodes) if runs else None
        mine = entries(board, runs, levels)
        rows += mine
        sections.append(f"## {board.name}\n\n{_about(board, levels, reference_episodes)}")
        sections[-1] += board_table(board, mine)
    usages = [
        usage
        for board in shared_boards(chosen, rows)
        for usage in headline_usage(board, runs_of[board.name], usage_episodes, rows)
    ]
    text = (
        "# Leaderboard\n\nGenerated by `python -m eval reproduce --study leaderboard` from the "
        "logged runs (the protocol: `maopg.experiment.studies.leaderboard`). Final return: on "
        "the boards whose study evaluates during training (Box Pushing), the value at the "
        "board's budget — the mean of the last 5 evaluations at or before it, sampled without "
        "ε —, elsewhere the mean training-episode return over a run's last 10 % of samples; "
        "samples to threshold on the same figure; normalised: (R − "
        "R_random) / (R_scripted − R_random) at the board's settings; intervals: percentile "
        "bootstrap 95 % over seeds (10,000 resamples); across boards: the interquartile mean "
        "with a stratified bootstrap interval (Agarwal et al., NeurIPS 2021), over finished "
        "runs only (one still training stands only in its board's table). "
        + TUNING_NOTE
        + pilot_budgets(out)
        + "\n\n## The paper's policy against the literature's\n\n"
        + headline_table(chosen, rows)
        + "\n### What their policies do\n\n"
        "On the boards all three share, each one's seed-0 policy (the weights the studies "
        f"keep), sampled over {usage_episodes} episodes "
        "(`maopg.experiment.studies.option_usage`): its return; the same run's final return "
        "as its board reads it (on the boards without evaluations during training, its "
        "training episodes over the last 10 % of samples, of which ACAC's and MacroMARL's "
        "rounds log only those that finish within a round: the two side by side show what "
        "that reading gives or takes); how often it succeeds, the episode's length in ticks, "
        "and every option each agent chose, by its share.\n\n"
        + (usage_table(usages) if usages else "No board yet.\n")
        + "\n## Across boards\n\n"
        + aggregate_table(chosen, rows)
        + "\n"
        "![performance profile](performance_profile.png)\n\n" + "\n\n".join(sections) + "\n"
    )
    written = [out / "tables.md"]
    written[0].write_text(text)
    written.append(_write_scores(rows, out / "scores.csv"))
    written += plot_profile(rows, out / "performance_profile")
    return outcomes, written


def _about(board: Board, levels: tuple[float, float] | None, episodes: int) -> str:
    """The board's line: where it comes from, its settings, seeds, threshold and levels."""
    task = get_study(board.study).task(board.task)
    settings = ", ".join(f"{k}={v}" for k, v in task.settings.items()) or "default settings"
    threshold = "no threshold" if task.threshold is None else f"threshold {task.threshold:g}"
    line = (
        f"`{board.task}` of the `{board.study}` study ({settings}; {len(task.seeds)} seeds; "
        f"{threshold})"
    )
    if levels is None:
        return line + ": no runs yet.\n\n"
    return (
        line + f"; random {levels[0]:.1f}, scripted {levels[1]:.1f} over {episodes} episodes.\n\n"
    )


def _write_scores(rows: Sequence[Entry], path: Path) -> Path:
    """Every run's figures, one line each, for other tools."""
    lines = ["board,method,seed,final_return,normalised,samples_to_threshold,finished,samples"]
    lines += [
        f"{e.board},{e.method},{e.seed},{e.final_return:.4f},{e.score:.4f},"
        f"{e.to_threshold:.0f},{int(e.finished)},{e.samples:.0f}"
        for e in rows
    ]
    path.write_text("\n".join(lines) + "\n")
    return path

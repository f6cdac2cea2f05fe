"""The study registry: a name → the grid of runs one ``eval reproduce`` brings to completion.

A study is a set of tasks — each at its own task settings (a team size, say) and seeds — times a
set of methods, plus train settings every run shares (a sample budget, camera observations).
``paper`` is the committed reproduction of the paper, built from the task and method registries
at the time it is asked for (so a plugin's task or method joins it); the others answer one
question each and keep their runs and results in a folder of their own, ``results/<study>/``,
so no two studies pool their runs. Within a study a task appears once: runs are grouped by
task (``<runs>/<task>/<method>/seed<seed>``), and so are its curves and tables.

A study whose question is "how close to the scripted heuristic" sets ``normalised``: its tables
add each method's final return as the normalised score ``(R − R_random) / (R_scripted −
R_random)`` against the reference policies measured at the study's own task settings.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from maopg.experiment.methods import grid_method_names
from maopg.tasks import task_entry, task_names


@dataclass(frozen=True)
class StudyTask:
    """One task of a study, at its settings and seeds."""

    task: str
    seeds: tuple[int, ...]
    settings: Mapping[str, Any] = field(default_factory=dict)
    """Task settings (``env.KEY=VALUE`` of ``train``) of every run and reference evaluation."""
    overrides: tuple[str, ...] = ()
    """Train ``key=value`` settings of every run on this task (its sample budget, say)."""
    method_overrides: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    """Train ``key=value`` settings of one method's runs on this task only."""

    def train_args(self, method: str) -> list[str]:
        """The ``key=value`` arguments this task adds to a run of ``method``."""
        settings = [f"env.{key}={_text(value)}" for key, value in self.settings.items()]
        return [*settings, *self.overrides, *self.method_overrides.get(method, ())]


def _text(value: Any) -> str:
    """A task setting as ``train`` parses it back (tuples as comma lists)."""
    if isinstance(value, tuple | list):
        return ",".join(_text(v) for v in value)
    return str(value).lower() if isinstance(value, bool) else str(value)


@dataclass(frozen=True)
class Study:
    name: str
    about: str
    tasks: tuple[StudyTask, ...]
    methods: tuple[str, ...]
    overrides: tuple[str, ...] = ()
    """Train ``key=value`` settings of every run (before the user's own)."""
    normalised: bool = False
    """Add the normalised final score to the tables (module docstring)."""
    baselines: tuple[str, ...] = ()
    """Methods whose finished runs of the ``paper`` study join this study's figures and tables
    (read, never trained here): the committed grid a variant is compared with. Only for tasks
    at their default settings, where the paper's runs are the same experiment."""

    def __post_init__(self) -> None:
        names = [t.task for t in self.tasks]
        if len(set(names)) != len(names):
            raise ValueError(f"study {self.name!r} lists a task twice: {names}")
        if self.baselines and any(t.settings for t in self.tasks):
            raise ValueError(
                f"study {self.name!r}: baselines come from the paper's runs, at default task "
                "settings, and this study changes them"
            )

    def task(self, name: str) -> StudyTask:
        for study_task in self.tasks:
            if study_task.task == name:
                return study_task
        raise ValueError(f"task {name!r} is not part of study {self.name!r}")

    def runs_dir(self) -> Path:
        """Default run root (relative to the working directory)."""
        return Path("results/runs") if self.name == PAPER else Path("results", self.name, "runs")

    def results_dir(self) -> Path:
        return Path("results") if self.name == PAPER else Path("results", self.name)


PAPER = "paper"


def _paper() -> Study:
    """Every registered task at its defaults and declared grid seeds, every grid method."""
    tasks = tuple(
        StudyTask(t, task_entry(t).grid_seeds, method_overrides=task_entry(t).grid_overrides)
        for t in task_names()
    )
    about = "the paper's comparison: every grid method on every task at its default settings"
    return Study(PAPER, about, tasks, tuple(grid_method_names()))


_STUDIES: dict[str, Callable[[], Study]] = {PAPER: _paper}


def register_study(name: str, build: Callable[[], Study], *, overwrite: bool = False) -> None:
    """Add a study (``build`` makes it when asked for, so it may read the registries then)."""
    if name in _STUDIES and not overwrite:
        raise ValueError(f"study {name!r} is already registered (pass overwrite=True)")
    _STUDIES[name] = build


def get_study(name: str) -> Study:
    try:
        return _STUDIES[name]()
    except KeyError:
        known = ", ".join(_STUDIES)
        raise ValueError(f"unknown study {name!r}; known studies: {known}") from None


def study_names() -> list[str]:
    return list(_STUDIES)


def frozen(settings: Mapping[str, Any]) -> Mapping[str, Any]:
    """A read-only copy, for settings kept in a frozen study."""
    return MappingProxyType(dict(settings))


# ----------------------------------------------------------------------------- the studies
TEAM_OF_EIGHT = {
    "tool_delivery": {"turtlebots": 6, "fetches": 2, "humans": 3},
    "water_filling": {"vehicles": 4, "drones": 4, "jars": 8},
}
"""The issue's teams of eight robots: 15.3M joint options on Tool Delivery, 9.8·10⁹ on Water
Filling, where only the factored policies fit (``bench/policy_scaling.py``)."""


def _teams() -> Study:
    """Teams of eight: the at-scale methods against the scripted and random references at the
    same size. Tool Delivery trains for 1M samples (the issue's budget for its ≥ 0.8 target).
    Water Filling trains from state: the question is the team size, and its eight cameras
    would triple the cost of every sample (the memory study is the one from RGB).

    Tool Delivery's team plays with ``mask_options``: each option keeps to its initiation set
    (no pass with nothing staged, no search that cannot find a tool). Under the canonical rules,
    where those options run and waste ticks, ``async-ar`` at 6/2/3 never delivers a tool: it
    settles at exactly −150 within 20K samples, with a failed pass costing −10 or nothing, with
    ``ppo.ent_coef=0.05`` and with ten times the batch (BENCHMARKS.md, "Tool Delivery team
    sizes"). With the masks the same run passes 400 by 60K samples (README, "Studies", has the
    commands). The references are measured at the same settings, masks included, so the
    normalised score compares like with like."""
    td = {**TEAM_OF_EIGHT["tool_delivery"], "mask_options": True}
    wf = TEAM_OF_EIGHT["water_filling"]
    return Study(
        "teams",
        "teams of eight robots: async-ar, partial-ar, sync-cut-ar, normalised scores",
        (
            StudyTask("tool_delivery", (0, 1, 2), frozen(td), ("total_samples=1000000",)),
            StudyTask("water_filling", (0, 1, 2), frozen(wf), ("images=false",)),
        ),
        ("async-ar", "partial-ar", "sync-cut-ar"),
        normalised=True,
    )


def _teams_canonical() -> Study:
    """The control of ``teams`` on Tool Delivery: its team of eight and budget under the
    canonical rules, where every option can be chosen at any time (no ``mask_options``). A pass
    with nothing staged or a search that cannot find a tool then runs and wastes its ticks, as
    in the paper's task; the question is whether ``async-ar`` still reaches 0.8 of the scripted
    heuristic in 1M samples, or whether ``teams``' result needs the initiation sets."""
    return Study(
        "teams-canonical",
        "async-ar on the Tool Delivery team of eight under the canonical rules (no masks)",
        (
            StudyTask(
                "tool_delivery",
                (0, 1, 2),
                frozen(TEAM_OF_EIGHT["tool_delivery"]),
                ("total_samples=1000000",),
            ),
        ),
        ("async-ar",),
        normalised=True,
    )


def _memory() -> Study:
    """Recurrent policies and critics on Water Filling from RGB (its defaults: 200K samples),
    beside the committed feed-forward runs of the same methods. Their GRUs read the option
    history and are layer-normalised (``ppo.option_history``, ``ppo.memory_norm``): without
    the norm the encoders' large features saturate the gates and the greedy policies loop
    (results/memory/README.md; the runs without both are kept in
    ``results/memory/unnormalised/``)."""
    return Study(
        "memory",
        "recurrent async, sync-wait and partial on Water Filling from RGB, beside the grid's",
        (StudyTask("water_filling", (0, 1, 2)),),
        ("async-rnn", "sync-wait-rnn", "partial-rnn"),
        overrides=("ppo.option_history=true", "ppo.memory_norm=true"),
        normalised=True,
        baselines=("async", "sync-wait", "partial"),
    )


def _chain_rule() -> Study:
    """The autoregressive conditional against the product categorical at the paper's size."""
    return Study(
        "chain-rule",
        "async-ar against the paper's async on Tool Delivery (state, 5 seeds, 100K samples)",
        (StudyTask("tool_delivery", (0, 1, 2, 3, 4)),),
        ("async-ar",),
        baselines=("async",),
    )


register_study("teams", _teams)
register_study("teams-canonical", _teams_canonical)
register_study("memory", _memory)
register_study("chain-rule", _chain_rule)

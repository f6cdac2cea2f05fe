"""The study registry: a name → the grid of runs one ``eval reproduce`` brings to completion.

A study is a set of tasks — each at its own task settings (a team size, say), seeds and return
threshold — times a set of methods, plus train settings every run shares (a sample budget,
camera observations). Everything a study adds to a task or a method lives here, not in the
task or method registries: those describe what a task and a method are, a study what one
experiment does with them. Settings are typed values under their command-line names
(``{"total_samples": 1_000_000, "ppo.option_history": True}``): the grid builds each run's
:class:`~maopg.experiment.run.config.TrainConfig` from them directly.

Each study answers one question and keeps its runs and results in a folder of its own
(``results/<study>/``; the ``paper`` study's are ``results/runs`` and ``results/``), so no two
studies pool their runs. Within a study a task appears once: runs are grouped by task
(``<runs>/<task>/<method>/seed<seed>``), and so are its curves and tables.

A study that sets its runs beside the literature's published curves names them in ``published``:
its tables read the runs' evaluations during training as the literature reads its own.

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

Settings = Mapping[str, Any]
"""Train settings by their command-line names: ``{"total_samples": 1000, "ppo.epochs": 5}``."""


def frozen(settings: Mapping[str, Any] | None = None) -> Mapping[str, Any]:
    """A read-only copy, for settings kept in a frozen study."""
    return MappingProxyType(dict(settings or {}))


@dataclass(frozen=True)
class StudyTask:
    """One task of a study, at its settings and seeds."""

    task: str
    seeds: tuple[int, ...]
    settings: Mapping[str, Any] = field(default_factory=frozen)
    """Task settings (``env.KEY=VALUE`` of ``train``) of every run and reference evaluation."""
    overrides: Settings = field(default_factory=frozen)
    """Train settings of every run on this task (its sample budget, say)."""
    method_overrides: Mapping[str, Settings] = field(default_factory=frozen)
    """Train settings of one method's runs on this task only."""
    threshold: float | None = None
    """Return threshold of the samples-to-threshold tables (``None``: no such column)."""

    def train_settings(self, method: str) -> dict[str, Any]:
        """The train settings this task gives a run of ``method``, task settings included
        (``env.KEY``), in the order they apply."""
        settings = {f"env.{key}": value for key, value in self.settings.items()}
        return {**settings, **self.overrides, **self.method_overrides.get(method, {})}


@dataclass(frozen=True)
class Study:
    name: str
    about: str
    tasks: tuple[StudyTask, ...]
    methods: tuple[str, ...]
    overrides: Settings = field(default_factory=frozen)
    """Train settings of every run (before the task's and the user's own)."""
    normalised: bool = False
    """Add the normalised final score to the tables (module docstring)."""
    baselines: tuple[str, ...] = ()
    """Methods whose finished runs of the ``paper`` study join this study's figures and tables
    (read, never trained here): the committed grid a variant is compared with. Only for tasks
    at their default settings, where the paper's runs are the same experiment."""
    published: str | None = None
    """The published Box Pushing curves (a key of
    :data:`~maopg.experiment.studies.published.PUBLISHED`: ``bp6``, ``bp8``, ``bp10``) that the
    study's evaluations during training are set beside, in tables and a figure of their own
    (:mod:`~maopg.experiment.studies.published`); its runs must evaluate (``eval_every``)."""

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

    def thresholds(self) -> dict[str, float]:
        """Each task's return threshold, where it declares one."""
        return {t.task: t.threshold for t in self.tasks if t.threshold is not None}

    def runs_dir(self) -> Path:
        """Default run root (relative to the working directory)."""
        return Path("results/runs") if self.name == PAPER else Path("results", self.name, "runs")

    def results_dir(self) -> Path:
        return Path("results") if self.name == PAPER else Path("results", self.name)


PAPER = "paper"
"""The committed reproduction of the paper's comparison."""

LEADERBOARD = "leaderboard"
"""Not a study but built from them: every method on every task that supports it, on one scale
(:mod:`maopg.experiment.studies.leaderboard`); ``eval reproduce --study leaderboard``."""
LEADERBOARD_ABOUT = (
    "every method on every task that supports it, reusing the studies' runs: final returns and "
    "normalised scores with bootstrap intervals, interquartile means across tasks"
)

VISION = "vision"
"""Not one study but several trained alike (:mod:`maopg.experiment.studies.vision`): ``async``
from cameras trained under two looks of the scenes, each evaluated in its own looks and in
held-out ones; ``eval reproduce --study vision``."""
VISION_ABOUT = (
    "async from RGB on Tool Delivery and Water Filling trained with env.appearance=off and "
    "full, each evaluated in-distribution and in held-out looks (normalised scores, targets); "
    "depth and RGB+depth pilots on Tool Delivery"
)

_STUDIES: dict[str, Callable[[], Study]] = {}


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


def declared_thresholds() -> dict[str, float]:
    """Every task's return threshold as the registered studies declare it (the first study
    that declares one wins; the ``paper`` study is registered first): the default of
    ``eval table``, whose runs belong to no study."""
    thresholds: dict[str, float] = {}
    for name in study_names():
        for task, value in get_study(name).thresholds().items():
            thresholds.setdefault(task, value)
    return thresholds

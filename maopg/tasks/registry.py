"""Task registry: everything specific to a task, declared once where the task registers.

A :class:`TaskEntry` names the task class and its config dataclass and carries what the rest of
the project would otherwise look up by task name: the scripted reference policy, what the video
panel shows of its state and its training defaults. What a study makes of a task (its seeds, a
return threshold, settings of one method's runs) belongs to the study
(:mod:`maopg.experiment.studies`), not here. Classes and functions may be given as
``"package.module:Attr"`` strings (dotted attributes allowed: ``"pkg.task:MyTask.Config"``),
imported on first use, so registering a task imports none of its simulation code.

``make_config`` validates overrides against the config's fields, so a typo fails loudly with the
nearest valid key instead of being silently ignored; the config checks each value's kind and
bounds itself (:class:`maopg.settings.Settings`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from maopg.exports import resolve
from maopg.settings import unknown_setting
from maopg.tasks.config import TaskConfig

if TYPE_CHECKING:
    from maopg.tasks.base import Task
    from maopg.tasks.panel import PanelFn
    from maopg.tasks.scripting import ScriptedFactory

StateLines = Callable[[Mapping[str, Any]], list[str]]
"""Formats a ``Task.describe()`` dict as the video panel's lines."""


@dataclass(frozen=True)
class TaskEntry:
    """A registered task and what the project needs to know about it."""

    name: str
    task: type[Task] | str
    """The task class, or ``"module:Class"``."""
    config: type[TaskConfig] | str
    """Its config dataclass, or ``"module:Class"``."""
    scripted: ScriptedFactory | str | None = None
    """``factory(config) -> policy(point) -> joint option``, the hand-written reference."""
    state_lines: StateLines | str | None = None
    """``describe()`` dict -> the video panel's lines of text, for a task without a ``panel``
    (default: ``generic_state_lines``)."""
    panel: PanelFn | str | None = None
    """``describe()`` dict -> the video panel's named quantities (:mod:`maopg.tasks.panel`:
    bars, named values, headings, text); it takes precedence over ``state_lines``."""
    train_defaults: Mapping[str, Any] = field(default_factory=dict)
    """Training-config fields this task defaults (``batch_ticks``, ``total_samples``, ...) and
    learner settings under their command-line names (``ppo.explore_eps``), which every method
    with that section takes unless the method or the user sets them."""
    defaults: Mapping[str, Any] = field(default_factory=dict)
    """Config settings this registration changes from the config class's own defaults (one
    class registered as several tasks: each wrapped PettingZoo environment, say)."""

    def task_class(self) -> type[Task]:
        from maopg.tasks.base import Task  # MuJoCo: only once a task is built

        cls = resolve(self.task)
        if not (isinstance(cls, type) and issubclass(cls, Task)):
            raise TypeError(f"task {self.name!r}: {self.task!r} is not a Task class")
        return cls

    def config_class(self) -> type[TaskConfig]:
        cls = resolve(self.config)
        if not (isinstance(cls, type) and issubclass(cls, TaskConfig)):
            raise TypeError(f"task {self.name!r}: {self.config!r} is not a TaskConfig dataclass")
        return cls

    def scripted_factory(self) -> ScriptedFactory | None:
        return resolve(self.scripted)

    def state_lines_fn(self) -> StateLines | None:
        return resolve(self.state_lines)

    def panel_fn(self) -> PanelFn | None:
        return resolve(self.panel)


_TASKS: dict[str, TaskEntry] = {}

RETIRED_KEYWORDS = ("grid_seeds", "threshold", "grid_overrides")
"""Keywords of :func:`register_task` in earlier releases, now a study's (refused, one line)."""


def register_task(
    name: str,
    task: type[Task] | str,
    *,
    config: type[TaskConfig] | str | None = None,
    scripted: ScriptedFactory | str | None = None,
    state_lines: StateLines | str | None = None,
    panel: PanelFn | str | None = None,
    train_defaults: Mapping[str, Any] | None = None,
    defaults: Mapping[str, Any] | None = None,
    overwrite: bool = False,
    **retired: Any,
) -> TaskEntry:
    """Register task ``name`` (a user's task plugs in here) and return its entry.

    ``config`` defaults to the task class's ``Config`` attribute (for a lazy ``"module:Class"``
    task: ``"module:Class.Config"``, looked up on first use). The grid keywords of earlier
    releases (``grid_seeds``, ``threshold``, ``grid_overrides``) are refused with a line that
    says where they went: a study declares them.
    """
    unexpected = sorted(set(retired) - set(RETIRED_KEYWORDS))
    if unexpected:
        raise TypeError(f"register_task() got unexpected keyword arguments {unexpected}")
    if retired:
        keys = ", ".join(f"{key}=" for key in sorted(retired))
        raise ValueError(
            f"register_task({keys}...): a grid's seeds, return threshold and per-method settings "
            "belong to a study now (maopg.experiment.studies: StudyTask(task, seeds, "
            "threshold=..., method_overrides=...), register_study)"
        )
    if name in _TASKS and not overwrite:
        raise ValueError(f"task {name!r} is already registered (pass overwrite=True)")
    if config is None and isinstance(task, str):
        config = f"{task}.Config"
    elif config is None:
        config = getattr(task, "Config", None)
        if config is None:
            raise ValueError(
                f"task {name!r}: {task.__name__} has no Config attribute; pass config="
            )
    entry = TaskEntry(
        name=name,
        task=task,
        config=config,
        scripted=scripted,
        state_lines=state_lines,
        panel=panel,
        train_defaults=MappingProxyType(dict(train_defaults or {})),
        defaults=MappingProxyType(dict(defaults or {})),
    )
    _TASKS[name] = entry
    return entry


def task_entry(name: str) -> TaskEntry:
    """The entry of a registered task (an unknown name lists the known ones)."""
    try:
        return _TASKS[name]
    except KeyError:
        raise ValueError(f"unknown task {name!r}; known tasks: {', '.join(task_names())}") from None


def task_names() -> list[str]:
    return sorted(_TASKS)


def task_class(name: str) -> type[Task]:
    return task_entry(name).task_class()


def make_config(name: str, overrides: Mapping[str, Any] | None = None) -> TaskConfig:
    """The task's default config (its registration's ``defaults`` applied) with ``overrides``
    applied. An unknown key is an error naming the nearest known one, and so is a value of the
    wrong kind or out of the field's declared bounds (:class:`maopg.settings.Settings`:
    ``max_ticks="abc"`` would otherwise fail mid-episode)."""
    entry = task_entry(name)
    config = entry.config_class()()
    overrides = {**entry.defaults, **(overrides or {})}
    fields = {f.name for f in dataclasses.fields(config)}
    unknown = sorted(set(overrides) - fields)
    if unknown:
        known = [f"{TaskConfig.PREFIX}{field}" for field in fields]
        raise unknown_setting(f"{TaskConfig.PREFIX}{unknown[0]}", known, f" of task {name!r}")
    return dataclasses.replace(config, **overrides)


def load(name: str, overrides: Mapping[str, Any] | None = None) -> Task:
    """Build task ``name`` with its default config updated by ``overrides``.

    The task takes the name it was registered under (a class registered twice, or under
    another name than its own, is still found by what the user asked for: the environment's
    spec, rollouts and videos look its entry up by ``task.name``)."""
    task = task_class(name)(make_config(name, overrides))
    task.name = name
    return task

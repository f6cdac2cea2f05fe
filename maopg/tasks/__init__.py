"""Task registry: ``load(name, overrides)`` builds a task from its config dataclass.

Each task module defines a frozen ``Config`` dataclass (extending
:class:`~maopg.tasks.base.TaskConfig`) and a :class:`~maopg.tasks.base.Task` subclass taking it.
Overrides are validated against the dataclass fields, so a typo fails loudly with the list of
valid keys instead of being silently ignored.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping
from typing import Any

from maopg.tasks.base import Task, TaskConfig

#: name -> "module:TaskClass"; imported lazily so loading one task does not import the others.
_TASKS: dict[str, str] = {
    "tool_delivery": "maopg.tasks.tool_delivery:ToolDelivery",
    "water_filling": "maopg.tasks.water_filling:WaterFilling",
}


def register_task(name: str, target: str, *, overwrite: bool = False) -> None:
    """Register a task class given as ``"module:Class"`` (a user's task plugs in here)."""
    if name in _TASKS and not overwrite:
        raise ValueError(f"task {name!r} is already registered (pass overwrite=True)")
    _TASKS[name] = target


def task_names() -> list[str]:
    return sorted(_TASKS)


def task_class(name: str) -> type[Task]:
    if name not in _TASKS:
        raise ValueError(f"unknown task {name!r}; known tasks: {', '.join(task_names())}")
    module, cls = _TASKS[name].split(":")
    return getattr(importlib.import_module(module), cls)


def make_config(name: str, overrides: Mapping[str, Any] | None = None) -> TaskConfig:
    """The task's default config with ``overrides`` applied (unknown keys are an error)."""
    cls = task_class(name)
    config = cls.Config()
    overrides = dict(overrides or {})
    fields = {f.name for f in dataclasses.fields(config)}
    unknown = sorted(set(overrides) - fields)
    if unknown:
        raise ValueError(
            f"unknown config key(s) {unknown} for task {name!r}; valid keys: {sorted(fields)}"
        )
    return dataclasses.replace(config, **overrides)


def load(name: str, overrides: Mapping[str, Any] | None = None) -> Task:
    """Build task ``name`` with its default config updated by ``overrides``."""
    return task_class(name)(make_config(name, overrides))


__all__ = ["Task", "TaskConfig", "load", "make_config", "register_task", "task_names"]

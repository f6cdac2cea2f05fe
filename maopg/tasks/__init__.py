"""Tasks: the :class:`~maopg.tasks.base.Task` interface, the registry and the built-in tasks.

Each built-in task is a package (``maopg/tasks/<task>/``: constants, config, options, the task,
its scripted policy) that registers itself in its ``__init__`` with lazy ``"module:Attr"``
strings; importing this package imports those registrations only, not the simulation code.
"""

from __future__ import annotations

from maopg.tasks.base import SceneTask, Task, TaskConfig
from maopg.tasks.layout import ObsLayout
from maopg.tasks.registry import (
    TaskEntry,
    load,
    make_config,
    register_task,
    task_class,
    task_entry,
    task_names,
)

# The built-ins register themselves on import (after the registry above exists).
from maopg.tasks import box_pushing, box_pushing_grid, tool_delivery, water_filling  # noqa: F401  isort: skip

__all__ = [
    "ObsLayout",
    "SceneTask",
    "Task",
    "TaskConfig",
    "TaskEntry",
    "load",
    "make_config",
    "register_task",
    "task_class",
    "task_entry",
    "task_names",
]

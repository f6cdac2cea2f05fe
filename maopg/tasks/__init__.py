"""Tasks: the :class:`~maopg.tasks.base.Task` interface, the registry and the built-in tasks.

Each built-in task is a package (``maopg/tasks/<task>/``: constants, config, options, the task,
its scripted policy) that registers itself in its ``__init__`` with lazy ``"module:Attr"``
strings; importing this package imports those registrations only, not the simulation code:
:class:`Task`, :class:`SceneTask` (MuJoCo) and :class:`ObsLayout` (numpy) are imported on first
use (:mod:`maopg.exports`).
"""

from __future__ import annotations

from maopg.exports import lazy_exports
from maopg.tasks.config import TaskConfig
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

_, __getattr__, __dir__ = lazy_exports(
    __name__,
    ("maopg.tasks.base:SceneTask", "maopg.tasks.base:Task", "maopg.tasks.layout:ObsLayout"),
)

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

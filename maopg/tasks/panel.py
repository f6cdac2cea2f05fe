"""What a video's panel shows of a task's state: named quantities, not raw vectors.

A task's ``display`` module turns its :meth:`~maopg.tasks.base.Task.describe` dict into a list
of these items (registered as the task's ``panel``, :func:`~maopg.tasks.registry.register_task`)
and the video draws them (:mod:`maopg.env.panel`), as dm_control's tasks say what an
observation means while the physics knows no task. A plain string is a line of text, so a
task registered with ``state_lines`` only, or with nothing (its ``describe()`` as
``key: value`` lines, :func:`~maopg.tasks.text.generic_state_lines`), still gets a panel.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Heading:
    """The title of the items under it (dim, smaller)."""

    text: str


@dataclass(frozen=True)
class Field:
    """A named value: ``name`` in a column of its own, ``value`` beside it."""

    name: str
    value: str


@dataclass(frozen=True)
class Gauge:
    """A named quantity as a bar: ``name``, the bar filled to ``fraction`` (0 to 1, clipped),
    and ``text`` after it; ``mark``, a second fraction shown as a tick on the bar (Water
    Filling: the level the robots last saw of a jar)."""

    name: str
    fraction: float
    text: str = ""
    mark: float | None = None


PanelItem = str | Heading | Field | Gauge
PanelFn = Callable[[Mapping[str, Any]], list[PanelItem]]
"""A task's ``describe()`` dict -> the panel's items, top to bottom."""

"""Options: macro-actions with an inner controller, a termination condition and interruption.

An option never touches ``data.ctrl``: its per-tick ``step`` gives a command to its robot's
adapter (``drive_to``, ``fly_to``, ``set_arm_targets``...), and the adapter's PD/servo loop
turns that into actuator controls while the physics advances. Options are stateless objects
shared across episodes; what one execution needs to remember (ticks run, targets) lives in the
:class:`Execution` record the environment keeps per agent.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from maopg.tasks.base import Task


@dataclass
class Execution:
    """One running instance of an option for one agent."""

    option: Option
    agent: int
    started_tick: int
    ticks: int = 0
    """Ticks this execution has run (incremented after each tick)."""
    memo: dict[str, Any] = field(default_factory=dict)
    """Option-private state of this execution (targets, progress)."""


class Option(ABC):
    """A macro-action of one agent.

    The environment calls, in this order: ``available`` (to build the mask), ``start`` when the
    agent picks it, then every tick ``step`` (before physics) and ``done`` (after physics and the
    task's rules), ``interrupt`` if the ``any`` strategy cuts it short, and ``finish`` once the
    execution has stopped either way.
    """

    name: str = "option"

    def available(self, task: Task, agent: int) -> bool:
        """Whether the agent may pick this option now (unavailable options are masked)."""
        return True

    def start(self, task: Task, ex: Execution) -> None:  # noqa: B027 (optional hook)
        """Called once when the option is picked, before its first tick."""

    @abstractmethod
    def step(self, task: Task, ex: Execution) -> None:
        """Give the robot's adapter this tick's command."""

    @abstractmethod
    def done(self, task: Task, ex: Execution) -> bool:
        """Termination condition, evaluated after each tick."""

    def interrupt(self, task: Task, ex: Execution) -> None:
        """Stop early (``any`` strategy): by default the robot simply holds its pose."""
        task.hold(ex.agent)

    def finish(self, task: Task, ex: Execution) -> None:  # noqa: B027 (optional hook)
        """Called once when the execution stops, after ``done`` or ``interrupt``."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"

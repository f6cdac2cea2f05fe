"""Options: macro-actions with an inner controller, a termination condition and interruption.

An option never touches ``data.ctrl``: its per-tick ``step`` asks its task for a command
(``head_for``, ``hold``, a task's own verbs), and the task hands it to the robot's adapter, whose
PD/servo loop turns it into actuator controls while the physics advances. Options are stateless
objects shared across episodes; what one execution needs to remember (ticks run, targets) lives
in the :class:`Execution` record the environment keeps per agent.

Options sit below tasks (``sim → options → tasks``), so they never see a task class. An option
is written against a small :class:`~typing.Protocol` of what it needs — :class:`AgentControl`
for every option, :class:`MobileTask` for moves and navigation, a task's own protocol for its
own options — and a task passes itself wherever it satisfies that protocol. Whatever an option
does to the task's rules goes through a method of that protocol (a hook such as
:meth:`MobileTask.motion_started`), never through the task's state.
"""

from __future__ import annotations

import enum
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Generic, Protocol, TypeVar


class Strategy(enum.StrEnum):
    """How option terminations of different agents are reconciled (docs/DESIGN.md §3; the
    option-level contract, :mod:`maopg.env.contract`, says what each does). Defined with the
    options, below the tasks, so that a task can declare the strategies it runs under."""

    CONTINUE = "continue"
    ANY = "any"
    ALL = "all"
    PRIMITIVE = "primitive"

    @classmethod
    def _missing_(cls, value: object) -> Strategy:
        """A name that is none of them: the error lists those that are."""
        known = ", ".join(strategy.value for strategy in cls)
        raise ValueError(f"unknown strategy {value!r}; the strategies are: {known}")


class AgentControl(Protocol):
    """What every option may ask of its task."""

    def hold(self, agent: int) -> None:
        """Command the agent's robot to stay put this tick."""


class MobileTask(AgentControl, Protocol):
    """A task whose agents drive or fly in the plane: what moves and navigation options need."""

    def planar_position(self, agent: int) -> tuple[float, float]:
        """World ``(x, y)`` of the agent's robot (m)."""

    def step_length(self, agent: int) -> float:
        """Distance of a one-tick move of the agent (m)."""

    def head_for(self, agent: int, xy: Sequence[float]) -> None:
        """This tick's tracking command: toward the planar point ``xy``."""

    def arrived(self, agent: int, xy: Sequence[float]) -> bool:
        """Whether the agent's robot is at ``xy`` within the task's arrival tolerance."""

    def motion_started(self, agent: int) -> None:
        """Hook: the agent starts moving under an option of its own (a task drops whatever
        standing still meant, e.g. waiting for a hand-over)."""


TaskT = TypeVar("TaskT", bound=AgentControl, contravariant=True)


@dataclass
class Execution:
    """One running instance of an option for one agent."""

    option: Option[Any]
    agent: int
    started_tick: int
    ticks: int = 0
    """Ticks this execution has run (incremented after each tick)."""
    memo: dict[str, Any] = field(default_factory=dict)
    """Option-private state of this execution (targets, progress)."""


class Option(ABC, Generic[TaskT]):
    """A macro-action of one agent, acting on a task of type ``TaskT``.

    The environment calls, in this order: ``available`` (to build the mask), ``start`` when the
    agent picks it, then every tick ``step`` (before physics) and ``done`` (after physics and the
    task's rules), ``interrupt`` if the ``any`` strategy cuts it short, and ``finish`` once the
    execution has stopped either way.
    """

    name: str = "option"

    def available(self, task: TaskT, agent: int) -> bool:
        """Whether the agent may pick this option now (unavailable options are masked)."""
        return True

    def start(self, task: TaskT, ex: Execution) -> None:
        """Called once when the option is picked, before its first tick."""

    @abstractmethod
    def step(self, task: TaskT, ex: Execution) -> None:
        """Give the robot this tick's command."""

    @abstractmethod
    def done(self, task: TaskT, ex: Execution) -> bool:
        """Termination condition, evaluated after each tick."""

    def interrupt(self, task: TaskT, ex: Execution) -> None:
        """Stop early (``any`` strategy): by default the robot simply holds its pose."""
        task.hold(ex.agent)

    def finish(self, task: TaskT, ex: Execution) -> None:
        """Called once when the execution stops, after ``done`` or ``interrupt``."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


def option_index(names: Sequence[str], name: str, agent: str) -> int:
    """Index of the option called ``name`` among agent ``agent``'s option ``names``.

    Options are addressed by name wherever code chooses one (scripted policies, tests): their
    positions are fixed only by the order a task builds them in.
    """
    try:
        return list(names).index(name)
    except ValueError:
        raise ValueError(
            f"agent {agent!r} has no option {name!r}; its options: {list(names)}"
        ) from None

"""Box Pushing's option sets: the grid's eight macro-actions on physical robots, or its four
primitive actions (``BP-v0``'s) for the end2end baseline.

The GoTos are the shared :class:`~maopg.options.navigation.NavigateTo` (the task plans a route
around the boxes and ends it facing north); Push, the turns and Stay are this task's own and
act on it only through :class:`PushingRules`, which
:class:`~maopg.tasks.box_pushing.task.BoxPushing` implements.
"""

from __future__ import annotations

import math
from typing import Any, Protocol

from maopg.options.base import Execution, Option
from maopg.options.navigation import NavigateTo, RoutedTask
from maopg.tasks.box_pushing.config import Config
from maopg.tasks.box_pushing_grid.world import (
    FORWARD,
    MACROS,
    PRIMITIVES,
    PUSH,
    STAY,
    TURN_LEFT,
    TURN_RIGHT,
)

GO_TOS = MACROS[:PUSH]
"""The GoTo macro-actions; a GoTo's index is its waypoint's."""


class PushingRules(RoutedTask, Protocol):
    """What Box Pushing's own options ask of the task."""

    def begin_push(self, agent: int, *, one_cell: bool) -> None:
        """Start driving ahead along the agent's lane: to the wall, or one cell."""

    def push_on(self, agent: int) -> None:
        """This tick's command of the agent's push."""

    def push_over(self, agent: int) -> bool:
        """The push ended on the last tick (lane end, stall, wall, or its one cell)."""

    def end_push(self, agent: int) -> None:
        """Forget the agent's push (it ended or was cut short)."""

    def heading_yaw(self, agent: int) -> float:
        """The yaw of the compass direction the agent's robot faces most nearly."""

    def turn(self, agent: int, yaw: float) -> None:
        """This tick's command: stand and turn to ``yaw``."""

    def faces(self, agent: int, yaw: float) -> bool:
        """The agent's robot faces ``yaw`` within the task's tolerance."""


class Push(Option[PushingRules]):
    """Drive ahead until a box reaches the goal strip, the robot reaches the wall, or it stalls
    (``one_cell``: the primitive MoveForward, one cell and one tick)."""

    def __init__(self, name: str, *, one_cell: bool = False) -> None:
        self.name, self.one_cell = name, one_cell

    def start(self, task: PushingRules, ex: Execution) -> None:
        task.begin_push(ex.agent, one_cell=self.one_cell)

    def step(self, task: PushingRules, ex: Execution) -> None:
        task.push_on(ex.agent)

    def done(self, task: PushingRules, ex: Execution) -> bool:
        return task.push_over(ex.agent)

    def finish(self, task: PushingRules, ex: Execution) -> None:
        task.end_push(ex.agent)


class Turn(Option[PushingRules]):
    """A quarter turn on the spot (``quarter`` +1: left, -1: right) from the compass heading;
    ends facing the new one, or after ``limit`` ticks (a robot in the way)."""

    def __init__(self, name: str, quarter: int, limit: int) -> None:
        self.name, self.quarter, self.limit = name, quarter, limit

    def start(self, task: PushingRules, ex: Execution) -> None:
        ex.memo["yaw"] = task.heading_yaw(ex.agent) + self.quarter * math.pi / 2

    def step(self, task: PushingRules, ex: Execution) -> None:
        task.turn(ex.agent, ex.memo["yaw"])

    def done(self, task: PushingRules, ex: Execution) -> bool:
        return ex.ticks >= self.limit or task.faces(ex.agent, ex.memo["yaw"])


class Stay(Option[PushingRules]):
    """Stand still for one tick."""

    name = MACROS[STAY]

    def step(self, task: PushingRules, ex: Execution) -> None:
        task.hold(ex.agent)

    def done(self, task: PushingRules, ex: Execution) -> bool:
        return True


def option_set(config: Config) -> tuple[Option[Any], ...]:
    """Every agent's options, in the grid's index order: the 8 macro-actions, or the 4
    primitive ones (MoveForward, TurnLeft, TurnRight, Stay: one tick each) when
    ``config.primitive``."""
    turn_limit = 1 if config.primitive else config.turn_ticks
    turns = (
        Turn(MACROS[TURN_LEFT], 1, turn_limit),
        Turn(MACROS[TURN_RIGHT], -1, turn_limit),
    )
    if config.primitive:
        return (Push(PRIMITIVES[FORWARD], one_cell=True), *turns, Stay())
    return (
        *(NavigateTo(name, k) for k, name in enumerate(GO_TOS)),
        Push(MACROS[PUSH]),
        *turns,
        Stay(),
    )

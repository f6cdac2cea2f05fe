"""Water Filling's option sets: compass moves (shared), Fill, NavTo and NavToFill.

Vehicle: 4 moves + Fill(c) + NavTo(c) + NavToFill(c) = 13 options, drone: 4 moves + NavTo(c) = 7
with the default 3 jars (the paper's table; ``4 + 3 * jars`` and ``4 + jars`` in general); in
primitive mode the vehicle has the moves and Fill (the nearest jar in reach), the drone the
moves. Every vehicle of a team has the vehicle's set, every drone the drone's. The options act
on the task only through :class:`JarRules`, which
:class:`~maopg.tasks.water_filling.task.WaterFilling` implements.
"""

from __future__ import annotations

from typing import Any, Protocol

from maopg.options.base import Execution, Option
from maopg.options.moves import Move
from maopg.options.navigation import NavigateTo, RoutedTask
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.constants import (
    FILL_NEAREST,
    MOVES,
    fill,
    nav_to,
    nav_to_fill,
)
from maopg.tasks.water_filling.team import Team


class JarRules(RoutedTask, Protocol):
    """What Water Filling's own options ask of the task (routes go to a jar's viewing spot)."""

    def can_fill(self, agent: int, jar: int) -> bool:
        """Vehicle ``agent`` is within fill reach of ``jar`` now."""

    def jar_in_reach(self, agent: int) -> int:
        """The nearest jar vehicle ``agent`` can fill now, or -1."""

    def request_fill(self, agent: int, jar: int) -> None:
        """Fill ``jar`` at the end of this tick if vehicle ``agent`` is then within reach."""

    def facing(self, agent: int, jar: int) -> bool:
        """The robot's camera points at ``jar``."""


class Fill(Option[JarRules]):
    """One tick holding still while filling jar ``jar`` (``None``: the nearest one in reach)."""

    def __init__(self, jar: int | None) -> None:
        self.jar = jar
        self.name = FILL_NEAREST if jar is None else fill(jar)

    def available(self, task: JarRules, agent: int) -> bool:
        if self.jar is None:
            return task.jar_in_reach(agent) >= 0
        return task.can_fill(agent, self.jar)

    def start(self, task: JarRules, ex: Execution) -> None:
        ex.memo["jar"] = task.jar_in_reach(ex.agent) if self.jar is None else self.jar

    def step(self, task: JarRules, ex: Execution) -> None:
        task.hold(ex.agent)
        task.request_fill(ex.agent, ex.memo["jar"])

    def done(self, task: JarRules, ex: Execution) -> bool:
        return True


class NavTo(NavigateTo):
    """Route navigation to jar ``jar`` (:class:`~maopg.options.navigation.NavigateTo`); with
    ``fill``, then one Fill tick there.

    Ends once the robot is at the route's end facing the jar (so its level is observed on that
    tick), or at the route's deadline.
    """

    def __init__(self, jar: int, *, fill: bool = False) -> None:
        super().__init__(nav_to_fill(jar) if fill else nav_to(jar), jar)
        self.jar, self.fill = jar, fill

    def start(self, task: JarRules, ex: Execution) -> None:
        super().start(task, ex)
        ex.memo["filling"] = False

    def step(self, task: JarRules, ex: Execution) -> None:
        if ex.memo["filling"]:
            task.hold(ex.agent)
            task.request_fill(ex.agent, self.jar)
        else:
            super().step(task, ex)

    def done(self, task: JarRules, ex: Execution) -> bool:
        if ex.memo["filling"]:
            return True  # the fill tick has run
        if not super().done(task, ex):
            return False
        if self.fill and task.can_fill(ex.agent, self.jar):
            ex.memo["filling"] = True
            return False
        return True


def option_sets(config: Config) -> list[tuple[Option[Any], ...]]:
    """Each agent's options, in the order checkpoints index them (options keep no state, so
    the robots of a kind share one set)."""
    team = Team.of(config)
    moves = tuple(Move(name, d) for name, d in MOVES)
    if config.primitive:
        vehicle, drone = (*moves, Fill(None)), moves
    else:
        jars = range(team.jars)
        vehicle = (
            *moves,
            *(Fill(c) for c in jars),
            *(NavTo(c) for c in jars),
            *(NavTo(c, fill=True) for c in jars),
        )
        drone = (*moves, *(NavTo(c) for c in jars))
    return [vehicle] * team.vehicles + [drone] * team.drones

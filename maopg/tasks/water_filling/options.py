"""Water Filling's option sets: compass moves (shared), Fill, NavTo and NavToFill.

Vehicle: 4 moves + Fill(c) + NavTo(c) + NavToFill(c) = 13 options, drone: 4 moves + NavTo(c) = 7
(the paper's table); in primitive mode the vehicle has the moves and Fill (the nearest jar in
reach), the drone the moves. The options act on the task only through :class:`JarRules`, which
:class:`~maopg.tasks.water_filling.task.WaterFilling` implements.
"""

from __future__ import annotations

from typing import Any, Protocol

from maopg.options.base import Execution, MobileTask, Option
from maopg.options.moves import Move
from maopg.sim.planning import Route
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.constants import (
    FILL_NEAREST,
    MOVES,
    NUM_JARS,
    fill,
    nav_to,
    nav_to_fill,
)


class JarRules(MobileTask, Protocol):
    """What Water Filling's own options ask of the task."""

    def can_fill(self, jar: int) -> bool:
        """The vehicle is within fill reach of ``jar`` now."""

    def jar_in_reach(self) -> int:
        """The nearest jar the vehicle can fill now, or -1."""

    def request_fill(self, jar: int) -> None:
        """Fill ``jar`` at the end of this tick if the vehicle is then within reach."""

    def route_to(self, agent: int, jar: int) -> Route:
        """A collision-free route of the agent's robot to its viewing spot of ``jar``."""

    def nav_deadline(self, agent: int, route: Route) -> int:
        """Ticks after which navigation along ``route`` gives up."""

    def follow(self, agent: int, route: Route, jar: int) -> None:
        """This tick's command along ``route``, turning to face ``jar`` at its end."""

    def facing(self, agent: int, jar: int) -> bool:
        """The robot's camera points at ``jar``."""


class Fill(Option[JarRules]):
    """One tick holding still while filling jar ``jar`` (``None``: the nearest one in reach)."""

    def __init__(self, jar: int | None) -> None:
        self.jar = jar
        self.name = FILL_NEAREST if jar is None else fill(jar)

    def available(self, task: JarRules, agent: int) -> bool:
        if self.jar is None:
            return task.jar_in_reach() >= 0
        return task.can_fill(self.jar)

    def start(self, task: JarRules, ex: Execution) -> None:
        ex.memo["jar"] = task.jar_in_reach() if self.jar is None else self.jar

    def step(self, task: JarRules, ex: Execution) -> None:
        task.hold(ex.agent)
        task.request_fill(ex.memo["jar"])

    def done(self, task: JarRules, ex: Execution) -> bool:
        return True


class NavTo(Option[JarRules]):
    """Plan a path to jar ``jar`` and follow it; with ``fill``, then one Fill tick there.

    Ends once the robot is at the route's end facing the jar (so its level is observed on that
    tick), or at the route's deadline.
    """

    def __init__(self, jar: int, *, fill: bool = False) -> None:
        self.jar, self.fill = jar, fill
        self.name = nav_to_fill(jar) if fill else nav_to(jar)

    def start(self, task: JarRules, ex: Execution) -> None:
        route = task.route_to(ex.agent, self.jar)
        ex.memo["route"] = route
        ex.memo["limit"] = task.nav_deadline(ex.agent, route)
        ex.memo["filling"] = False

    def step(self, task: JarRules, ex: Execution) -> None:
        if ex.memo["filling"]:
            task.hold(ex.agent)
            task.request_fill(self.jar)
        else:
            task.follow(ex.agent, ex.memo["route"], self.jar)

    def done(self, task: JarRules, ex: Execution) -> bool:
        if ex.memo["filling"]:
            return True  # the fill tick has run
        route = ex.memo["route"]
        arrived = route.update(task.planar_position(ex.agent)) and task.facing(ex.agent, self.jar)
        if not (arrived or ex.ticks >= ex.memo["limit"]):
            return False
        if self.fill and task.can_fill(self.jar):
            ex.memo["filling"] = True
            return False
        return True


def option_sets(config: Config) -> list[tuple[Option[Any], ...]]:
    """Each agent's options, in the order checkpoints index them."""
    moves = tuple(Move(name, d) for name, d in MOVES)
    if config.primitive:
        return [(*moves, Fill(None)), moves]
    jars = range(NUM_JARS)
    vehicle = (
        *moves,
        *(Fill(c) for c in jars),
        *(NavTo(c) for c in jars),
        *(NavTo(c, fill=True) for c in jars),
    )
    drone = (*moves, *(NavTo(c) for c in jars))
    return [vehicle, drone]

"""Navigation to a point, shared by the tasks: straight there (:class:`GoTo`, Tool Delivery's
GoToWS / GoToTR) or along a planned route around obstacles (:class:`NavigateTo`, the base of
Water Filling's NavTo), each tick's command given by the robot's own tracking controller.

Paths (``GoalFieldPlanner``, ``Route``) are geometry and live in :mod:`maopg.sim.planning`; the
task plans them, because only it knows its robots' planning grids and what "at the goal" means
(Water Filling: facing the jar, so its camera sees the level).
"""

from __future__ import annotations

from typing import Any, Protocol

from maopg.options.base import Execution, MobileTask, Option
from maopg.sim.planning import Route


class GoTo(Option[MobileTask]):
    """Head straight for a fixed point every tick; ends on arrival (Tool Delivery's GoToWS)."""

    def __init__(self, name: str, target: tuple[float, float]) -> None:
        self.name = name
        self.target = target

    def start(self, task: MobileTask, ex: Execution) -> None:
        task.motion_started(ex.agent)

    def step(self, task: MobileTask, ex: Execution) -> None:
        task.head_for(ex.agent, self.target)

    def done(self, task: MobileTask, ex: Execution) -> bool:
        return task.arrived(ex.agent, self.target)


class RoutedTask(MobileTask, Protocol):
    """What route navigation asks of a task; a goal is whatever key the task plans to (a jar)."""

    def route_to(self, agent: int, goal: Any) -> Route:
        """A collision-free route of the agent's robot to ``goal``, planned now."""

    def nav_deadline(self, agent: int, route: Route) -> int:
        """Ticks after which navigation along ``route`` gives up."""

    def follow(self, agent: int, route: Route, goal: Any) -> None:
        """This tick's command along ``route``."""

    def at_goal(self, agent: int, route: Route, goal: Any) -> bool:
        """After a tick: whether the robot has reached the end of ``route`` and settled at
        ``goal`` (the route's progress advances here)."""


class NavigateTo(Option[RoutedTask]):
    """Plan a route to ``goal`` at the start, follow it; ends at the goal or at the deadline."""

    def __init__(self, name: str, goal: Any) -> None:
        self.name = name
        self.goal = goal

    def start(self, task: RoutedTask, ex: Execution) -> None:
        route = task.route_to(ex.agent, self.goal)
        ex.memo["route"] = route
        ex.memo["limit"] = task.nav_deadline(ex.agent, route)

    def step(self, task: RoutedTask, ex: Execution) -> None:
        task.follow(ex.agent, ex.memo["route"], self.goal)

    def done(self, task: RoutedTask, ex: Execution) -> bool:
        arrived = task.at_goal(ex.agent, ex.memo["route"], self.goal)
        return arrived or ex.ticks >= ex.memo["limit"]

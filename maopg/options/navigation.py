"""Navigation to a fixed point: drive there with the robot's own tracking controller.

Paths around obstacles (``GoalFieldPlanner``, ``Route``) are geometry and live in
:mod:`maopg.sim.planning`; a task that needs them wraps them in options of its own (Water
Filling's ``NavTo``).
"""

from __future__ import annotations

from maopg.options.base import Execution, MobileTask, Option


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

"""One-tick compass moves: the primitive actions of mobile robots, shared by every such task."""

from __future__ import annotations

from maopg.options.base import Execution, MobileTask, Option

NORTH, SOUTH, EAST, WEST = (0.0, 1.0), (0.0, -1.0), (1.0, 0.0), (-1.0, 0.0)
"""Unit directions in the top view: north = +y, east = +x."""


class Move(Option[MobileTask]):
    """One tick toward the point one move's length away in a compass direction.

    The target is fixed at the start, so a robot that a wall or furniture stops simply stays
    short of it; the option always ends after its one tick.
    """

    def __init__(self, name: str, direction: tuple[float, float]) -> None:
        self.name = name
        self.direction = direction

    def start(self, task: MobileTask, ex: Execution) -> None:
        task.motion_started(ex.agent)
        x, y = task.planar_position(ex.agent)
        step = task.step_length(ex.agent)
        ex.memo["target"] = (x + step * self.direction[0], y + step * self.direction[1])

    def step(self, task: MobileTask, ex: Execution) -> None:
        task.head_for(ex.agent, ex.memo["target"])

    def done(self, task: MobileTask, ex: Execution) -> bool:
        return True

"""The shared options act on any task through the MobileTask protocol: a point robot suffices."""

from __future__ import annotations

import math
from collections.abc import Sequence

import pytest

from maopg.options.base import Execution, option_index
from maopg.options.moves import EAST, NORTH, SOUTH, WEST, Move
from maopg.options.navigation import GoTo


class PointRobots:
    """A MobileTask of point robots that move ``speed`` m straight toward their target per tick."""

    def __init__(self, *starts: tuple[float, float], speed: float = 0.5) -> None:
        self.xy = [list(s) for s in starts]
        self.speed = speed
        self.targets: list[Sequence[float] | None] = [None] * len(starts)
        self.events: list[tuple[str, int]] = []

    def planar_position(self, agent: int) -> tuple[float, float]:
        return tuple(self.xy[agent])

    def step_length(self, agent: int) -> float:
        return self.speed

    def head_for(self, agent: int, xy: Sequence[float]) -> None:
        self.targets[agent] = xy

    def hold(self, agent: int) -> None:
        self.targets[agent] = None
        self.events.append(("hold", agent))

    def arrived(self, agent: int, xy: Sequence[float]) -> bool:
        return math.dist(self.xy[agent], xy) <= 1e-9

    def motion_started(self, agent: int) -> None:
        self.events.append(("moving", agent))

    def tick(self) -> None:
        for agent, target in enumerate(self.targets):
            if target is None:
                continue
            x, y = self.xy[agent]
            d = math.dist((x, y), target)
            f = min(1.0, self.speed / d) if d else 0.0
            self.xy[agent] = [x + f * (target[0] - x), y + f * (target[1] - y)]


def run(task: PointRobots, option, agent: int = 0, limit: int = 50) -> int:
    """Run ``option`` to its end; the number of ticks it took."""
    ex = Execution(option, agent, started_tick=0)
    option.start(task, ex)
    while True:
        option.step(task, ex)
        task.tick()
        ex.ticks += 1
        if option.done(task, ex):
            option.finish(task, ex)
            return ex.ticks
        assert ex.ticks < limit


@pytest.mark.parametrize(
    ("direction", "expected"),
    [(NORTH, (1.0, 1.5)), (SOUTH, (1.0, 0.5)), (EAST, (1.5, 1.0)), (WEST, (0.5, 1.0))],
)
def test_move_goes_one_step_length_in_its_compass_direction(direction, expected) -> None:
    task = PointRobots((1.0, 1.0), (0.0, 0.0))
    assert run(task, Move("m", direction)) == 1
    assert task.planar_position(0) == pytest.approx(expected)
    assert task.planar_position(1) == (0.0, 0.0)
    assert task.events == [("moving", 0)], "the task hears that the agent set off"


def test_move_targets_from_where_the_robot_starts_not_where_it_ends() -> None:
    task = PointRobots((0.0, 0.0), speed=0.2)
    move = Move("East", EAST)
    ex = Execution(move, 0, started_tick=0)
    move.start(task, ex)
    task.xy[0] = [0.1, 0.0]  # pushed after the start: the target stays one step from the start
    move.step(task, ex)
    assert task.targets[0] == pytest.approx((0.2, 0.0))


def test_go_to_drives_until_arrival_and_interrupt_holds() -> None:
    task = PointRobots((0.0, 0.0), speed=0.5)
    go = GoTo("GoToA", (2.0, 0.0))
    assert run(task, go) == 4
    assert task.arrived(0, (2.0, 0.0)) and task.events == [("moving", 0)]
    ex = Execution(go, 0, started_tick=0)
    go.interrupt(task, ex)
    assert task.targets[0] is None and task.events[-1] == ("hold", 0)


def test_options_are_found_by_name() -> None:
    names = ["Up", "Down", "NavTo(0)"]
    assert option_index(names, "NavTo(0)", "drone") == 2
    with pytest.raises(ValueError, match=r"agent 'drone' has no option 'Fill'.*'Up', 'Down'"):
        option_index(names, "Fill", "drone")

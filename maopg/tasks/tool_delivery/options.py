"""Tool Delivery's option sets: the Turtlebots' trips and waits, the Fetch's activities.

The Turtlebots' GoToWS / GoToTR are the shared :class:`~maopg.options.navigation.GoTo` and their
primitive moves the shared :class:`~maopg.options.moves.Move`; GetTool, Stay and the Fetch's
activities are this task's own. They act on the task only through :class:`DeliveryRules`, which
:class:`~maopg.tasks.tool_delivery.task.ToolDelivery` implements.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

from maopg.options.base import Execution, MobileTask, Option
from maopg.options.moves import EAST, NORTH, SOUTH, WEST, Move
from maopg.options.navigation import GoTo
from maopg.tasks.tool_delivery.config import Config
from maopg.tasks.tool_delivery.constants import (
    GET_TOOL,
    GO_TO_TR,
    GO_TO_WS,
    NUM_TOOLS,
    STAY,
    TOOL_ROOM_WAIT,
    WAIT,
    WORKSHOP,
    pass_to,
    search_tool,
)


class DeliveryRules(MobileTask, Protocol):
    """What Tool Delivery's own options ask of the task (the Turtlebots are its mobile agents)."""

    def begin_waiting(self, w: int, *, primitive: bool = False) -> None:
        """Turtlebot ``w`` starts waiting for a pass (GetTool, or a primitive Stay)."""

    def waiting_over(self, w: int) -> bool:
        """A pass to ``w`` completed this tick, or ``w`` has waited longer than allowed."""

    def stop_waiting(self, w: int) -> None:
        """Turtlebot ``w`` no longer waits for a pass."""

    def activity_available(self, kind: str, arg: int) -> bool:
        """Whether the Fetch may pick activity ``kind(arg)`` now (``mask_options``)."""

    def continues(self, kind: str, arg: int) -> bool:
        """Whether the Fetch's unfinished activity is ``kind(arg)`` (primitive mode)."""

    def begin_activity(self, kind: str, arg: int) -> None:
        """Start a search, a pass or a wait of the Fetch."""

    def fetch_busy(self) -> bool:
        """The Fetch's activity has not finished yet."""

    def abort_activity(self) -> None:
        """Drop the Fetch's unfinished activity."""

    def command_arm(self) -> None:
        """This tick's arm set-points for the Fetch's activity."""


class GetTool(Option[DeliveryRules]):
    """Drive to the own desk spot and wait; ends when a pass to this robot completes, or after
    ``max_wait_ticks`` of waiting."""

    name = GET_TOOL

    def __init__(self, desk_spots: Sequence[Sequence[float]]) -> None:
        self.desk_spots = desk_spots

    def start(self, task: DeliveryRules, ex: Execution) -> None:
        task.begin_waiting(ex.agent)

    def step(self, task: DeliveryRules, ex: Execution) -> None:
        task.head_for(ex.agent, self.desk_spots[ex.agent])

    def done(self, task: DeliveryRules, ex: Execution) -> bool:
        return task.waiting_over(ex.agent)

    def finish(self, task: DeliveryRules, ex: Execution) -> None:
        task.stop_waiting(ex.agent)


class Stay(Option[DeliveryRules]):
    """Primitive: stay one tick; at the own desk spot this is waiting for a pass."""

    name = STAY

    def start(self, task: DeliveryRules, ex: Execution) -> None:
        task.begin_waiting(ex.agent, primitive=True)

    def step(self, task: DeliveryRules, ex: Execution) -> None:
        task.hold(ex.agent)

    def done(self, task: DeliveryRules, ex: Execution) -> bool:
        return True


class FetchActivity(Option[DeliveryRules]):
    """Wait (1 tick), PassTo(w) (4 ticks) or SearchTool(j) (6 ticks) as an option.

    In primitive mode (``one_tick``) the option lasts one tick and only *advances* the activity:
    a search or pass completes only if it is chosen for its whole duration.
    """

    def __init__(self, kind: str, arg: int = -1, *, one_tick: bool = False) -> None:
        self.kind, self.arg, self.one_tick = kind, arg, one_tick
        self.name = {"wait": WAIT, "pass": pass_to(arg), "search": search_tool(arg)}[kind]

    def available(self, task: DeliveryRules, agent: int) -> bool:
        return task.activity_available(self.kind, self.arg)

    def start(self, task: DeliveryRules, ex: Execution) -> None:
        if not (self.one_tick and task.continues(self.kind, self.arg)):
            task.begin_activity(self.kind, self.arg)

    def step(self, task: DeliveryRules, ex: Execution) -> None:
        task.command_arm()

    def done(self, task: DeliveryRules, ex: Execution) -> bool:
        return self.one_tick or not task.fetch_busy()

    def interrupt(self, task: DeliveryRules, ex: Execution) -> None:
        task.abort_activity()


def option_sets(config: Config) -> list[tuple[Option[Any], ...]]:
    """Each agent's options, in the order checkpoints index them (Turtlebots share theirs)."""
    one_tick = config.primitive
    fetch = (
        FetchActivity("pass", 0, one_tick=one_tick),
        FetchActivity("pass", 1, one_tick=one_tick),
        *(FetchActivity("search", j, one_tick=one_tick) for j in range(NUM_TOOLS)),
        FetchActivity("wait", one_tick=one_tick),
    )
    if one_tick:
        moves = (("North", NORTH), ("South", SOUTH), ("East", EAST), ("West", WEST))
        turtle: tuple[Option[Any], ...] = (*(Move(n, d) for n, d in moves), Stay())
    else:
        turtle = (
            GoTo(GO_TO_WS, WORKSHOP),
            GoTo(GO_TO_TR, TOOL_ROOM_WAIT),
            GetTool(config.desk_spots),
        )
    return [turtle, turtle, fetch]

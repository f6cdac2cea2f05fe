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
from maopg.tasks.tool_delivery.constants import STAY, WAIT, pass_to
from maopg.tasks.tool_delivery.team import Team


class DeliveryRules(MobileTask, Protocol):
    """What Tool Delivery's own options ask of the task (the Turtlebots are its mobile agents;
    a Fetch's hooks take its agent index)."""

    def begin_waiting(self, w: int, fetch: int = 0, *, primitive: bool = False) -> None:
        """Turtlebot ``w`` starts waiting for a pass from ``fetch`` (GetTool, or a primitive
        Stay at whichever desk spot it stands)."""

    def waiting_over(self, w: int) -> bool:
        """A pass to ``w`` completed this tick, or ``w`` has waited longer than allowed."""

    def stop_waiting(self, w: int) -> None:
        """Turtlebot ``w`` no longer waits for a pass."""

    def activity_available(self, agent: int, kind: str, arg: int) -> bool:
        """Whether the Fetch may pick activity ``kind(arg)`` now (``mask_options``)."""

    def continues(self, agent: int, kind: str, arg: int) -> bool:
        """Whether the Fetch's unfinished activity is ``kind(arg)`` (primitive mode)."""

    def begin_activity(self, agent: int, kind: str, arg: int) -> None:
        """Start a search, a pass or a wait of the Fetch."""

    def fetch_busy(self, agent: int) -> bool:
        """The Fetch's activity has not finished yet."""

    def abort_activity(self, agent: int) -> None:
        """Drop the Fetch's unfinished activity."""

    def command_arm(self, agent: int) -> None:
        """This tick's arm set-points for the Fetch's activity."""


class GetTool(Option[DeliveryRules]):
    """Drive to the own desk spot at Fetch ``fetch`` and wait; ends when a pass to this robot
    completes, or after ``max_wait_ticks`` of waiting."""

    def __init__(self, name: str, fetch: int, desk_spots: Sequence[Sequence[float]]) -> None:
        self.name, self.fetch = name, fetch
        self.desk_spots = desk_spots
        """Each Turtlebot's spot at this Fetch's desk."""

    def start(self, task: DeliveryRules, ex: Execution) -> None:
        task.begin_waiting(ex.agent, self.fetch)

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
    """Wait (1 tick), PassTo(w) (4 ticks) or SearchTool (6 ticks) as an option; ``arg`` is the
    Turtlebot of a pass, the tool (``3h + j``) of a search.

    In primitive mode (``one_tick``) the option lasts one tick and only *advances* the activity:
    a search or pass completes only if it is chosen for its whole duration.
    """

    def __init__(self, name: str, kind: str, arg: int = -1, *, one_tick: bool = False) -> None:
        self.name, self.kind, self.arg, self.one_tick = name, kind, arg, one_tick

    def available(self, task: DeliveryRules, agent: int) -> bool:
        return task.activity_available(agent, self.kind, self.arg)

    def start(self, task: DeliveryRules, ex: Execution) -> None:
        if not (self.one_tick and task.continues(ex.agent, self.kind, self.arg)):
            task.begin_activity(ex.agent, self.kind, self.arg)

    def step(self, task: DeliveryRules, ex: Execution) -> None:
        task.command_arm(ex.agent)

    def done(self, task: DeliveryRules, ex: Execution) -> bool:
        return self.one_tick or not task.fetch_busy(ex.agent)

    def interrupt(self, task: DeliveryRules, ex: Execution) -> None:
        task.abort_activity(ex.agent)


def option_sets(config: Config) -> list[tuple[Option[Any], ...]]:
    """Each agent's options, in the order checkpoints index them (Turtlebots share theirs).

    A Turtlebot: ``GoToWS`` per workshop, ``GoToTR`` per bay, ``GetTool`` per Fetch. A Fetch:
    ``PassTo(w)`` per Turtlebot, ``SearchTool`` per tool on its shelves, ``Wait``.
    """
    team, one_tick = Team.of(config), config.primitive
    fetches = [
        (
            *(FetchActivity(pass_to(w), "pass", w, one_tick=one_tick) for w in team.turtlebot_ids),
            *(
                FetchActivity(team.search_tool(t), "search", t, one_tick=one_tick)
                for t in team.tools_of(f)
            ),
            FetchActivity(WAIT, "wait", one_tick=one_tick),
        )
        for f in team.fetch_ids
    ]
    if one_tick:
        moves = (("North", NORTH), ("South", SOUTH), ("East", EAST), ("West", WEST))
        turtle: tuple[Option[Any], ...] = (*(Move(n, d) for n, d in moves), Stay())
    else:
        turtle = (
            *(GoTo(team.go_to_ws(h), xy) for h, xy in enumerate(team.workshops)),
            *(GoTo(team.go_to_tr(f), xy) for f, xy in enumerate(team.wait_spots)),
            *(
                GetTool(team.get_tool(f), f, [team.desk_spot(f, w) for w in team.turtlebot_ids])
                for f in team.fetch_ids
            ),
        )
    return [*(turtle for _ in team.turtlebot_ids), *fetches]

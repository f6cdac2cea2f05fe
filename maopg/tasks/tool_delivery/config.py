"""Tool Delivery's config, in a module of its own: the registry reads its defaults and
validates overrides without importing the simulation."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

from maopg.settings import setting
from maopg.tasks.config import SceneTaskConfig


@dataclass(frozen=True)
class Config(SceneTaskConfig):
    """Tool Delivery settings; the defaults are the canonical task's."""

    # The team (maopg/tasks/tool_delivery/team.py): one bay per Fetch, one workshop and tool
    # sequence per human; checked when the config is made (check_team). Turtlebots 2..5
    # wait for passes at team.EXTRA_DESK_SPOTS (0 and 1 at desk_spots); bay 1 mirrors bay 0.
    turtlebots: int = setting(2, ge=1, le=6)
    """Turtlebots, 1..6 (agents ``turtlebot0..``)."""
    fetches: int = setting(1, ge=1, le=2)
    """Fetches, 1 or 2, each with its own bay (agent ``fetch``; ``fetch0, fetch1`` for two)."""
    humans: int = setting(1, ge=1, le=4)
    """Humans, 1..2 x fetches, each with its own workshop and three tools."""
    max_ticks: int = 150
    tick_seconds: float = 1.0
    timestep: float = 0.02  # stable for the servos and welds; 50 physics steps per tick
    ROBOT_ROLES: ClassVar[Mapping[str, str]] = {"turtlebot_robot": "ground", "fetch_robot": "arm"}
    turtlebot_robot: str = "turtlebot"
    """The registered robot that plays the Turtlebots (a ground robot: ``diffbot``, a user's)."""
    fetch_robot: str = "fetch"
    """An arm (``ArmAdapter``): it stands at ``fetch_base`` and must reach the shelf slots, the
    desk slots and the baskets at the desk spots."""
    fetch_base: tuple[float, float] = (0.9, 1.8)
    """Planar position of the arm's base (m): the arena's Fetch spot beside the desk."""
    desk_spots: tuple[tuple[float, float], tuple[float, float]] = ((0.8, 3.0), (1.2, 3.0))
    """Where Turtlebot 0 / 1 waits for a pass (m): within the arm's reach with its basket."""
    human_stage_ticks: int = setting(18, ge=1)
    """Ticks a human works on each of its stages before the next tool can move it on."""
    search_ticks: int = setting(6, ge=1)
    """Ticks the Fetch takes to find a tool on the shelf and stage it on the desk."""
    pass_ticks: int = setting(4, ge=1)
    """Ticks the Fetch takes to pass a staged tool to a waiting Turtlebot."""
    max_wait_ticks: int = setting(10, ge=1)
    """Ticks a Turtlebot waits at the desk for a pass before ``GetTool`` gives up."""
    max_staged: int = setting(2, ge=1, le=2)
    """Tools the desk holds at once (its MJCF has two slots)."""
    step_reward: float = -1.0
    """Paid every tick."""
    delivery_reward: float = 100.0
    """Paid for each delivery of the tool a human needs now."""
    failed_pass_reward: float = -10.0
    """Paid for a pass to a Turtlebot that is not (or stops being) ready for it."""
    mask_options: bool = False
    """Mask searches of found tools (or with the desk full) and passes with nothing staged.
    Off by default: the canonical task lets the Fetch waste time on them."""
    arrive_tol: float = setting(0.05, gt=0.0)
    """A Turtlebot within this distance of a waypoint has arrived (m)."""
    primitive_step: float = setting(0.6, gt=0.0)
    """Distance of a one-tick primitive move (m): the Turtlebot's speed times one tick."""
    primitive_tol: float = setting(0.4, gt=0.0)
    """Arrival tolerance in primitive mode, where moves lie on a 0.6 m lattice."""

    def validate(self) -> None:
        """The fields' own bounds, then a team the layout has room for: the registry's
        ``make_config`` and a run's config check refuse it before any process builds it."""
        super().validate()
        if self.humans > MAX_HUMANS_PER_FETCH * self.fetches:
            raise ValueError(
                f"env.humans must be at most {MAX_HUMANS_PER_FETCH} x env.fetches (each Fetch's "
                f"bay has room for {MAX_HUMANS_PER_FETCH} shelves of tools), got "
                f"humans={self.humans} with fetches={self.fetches}"
            )


MAX_HUMANS_PER_FETCH = 2
"""The layout's room per bay (``maopg/tasks/tool_delivery/team.py`` says why; the field bounds
above hold the other limits: 6 Turtlebots, 2 Fetches)."""

"""Tool Delivery's config, in a module of its own: the registry reads its defaults and
validates overrides without importing the simulation."""

from __future__ import annotations

from dataclasses import dataclass

from maopg.tasks.base import TaskConfig


@dataclass(frozen=True)
class Config(TaskConfig):
    """Tool Delivery settings; the defaults are the canonical task's."""

    # The team (maopg/tasks/tool_delivery/team.py): one bay per Fetch, one workshop and tool
    # sequence per human; checked when the config is made (check_team). Turtlebots 2..5
    # wait for passes at team.EXTRA_DESK_SPOTS (0 and 1 at desk_spots); bay 1 mirrors bay 0.
    turtlebots: int = 2
    """Turtlebots, 1..6 (agents ``turtlebot0..``)."""
    fetches: int = 1
    """Fetches, 1 or 2, each with its own bay (agent ``fetch``; ``fetch0, fetch1`` for two)."""
    humans: int = 1
    """Humans, 1..2 x fetches, each with its own workshop and three tools."""
    max_ticks: int = 150
    tick_seconds: float = 1.0
    timestep: float = 0.02  # stable for the servos and welds; 50 physics steps per tick
    turtlebot_robot: str = "turtlebot"
    fetch_robot: str = "fetch"
    """An arm (``ArmAdapter``): it stands at ``fetch_base`` and must reach the shelf slots, the
    desk slots and the baskets at the desk spots."""
    fetch_base: tuple[float, float] = (0.9, 1.8)
    """Planar position of the arm's base (m): the arena's Fetch spot beside the desk."""
    desk_spots: tuple[tuple[float, float], tuple[float, float]] = ((0.8, 3.0), (1.2, 3.0))
    """Where Turtlebot 0 / 1 waits for a pass (m): within the arm's reach with its basket."""
    human_stage_ticks: int = 18
    search_ticks: int = 6
    pass_ticks: int = 4
    max_wait_ticks: int = 10
    max_staged: int = 2
    step_reward: float = -1.0
    delivery_reward: float = 100.0
    failed_pass_reward: float = -10.0
    mask_options: bool = False
    """Mask searches of found tools (or with the desk full) and passes with nothing staged.
    Off by default: the canonical task lets the Fetch waste time on them."""
    arrive_tol: float = 0.05
    """A Turtlebot within this distance of a waypoint has arrived (m)."""
    primitive_step: float = 0.6
    """Distance of a one-tick primitive move (m): the Turtlebot's speed times one tick."""
    primitive_tol: float = 0.4
    """Arrival tolerance in primitive mode, where moves lie on a 0.6 m lattice."""

    def __post_init__(self) -> None:
        """Refuse a team the layout has no room for as soon as the config is made (the
        registry's ``make_config``, a run's config check), before any process builds it."""
        check_team(self)


MAX_TURTLEBOTS, MAX_FETCHES, MAX_HUMANS_PER_FETCH = 6, 2, 2
"""The team sizes the layout has room for (``maopg/tasks/tool_delivery/team.py`` says why)."""


def check_team(config: Config) -> None:
    """Refuse a team the layout has no room for, with one line naming the setting."""
    for name, value, top in (
        ("turtlebots", config.turtlebots, MAX_TURTLEBOTS),
        ("fetches", config.fetches, MAX_FETCHES),
        ("humans", config.humans, MAX_HUMANS_PER_FETCH * MAX_FETCHES),
    ):
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= top:
            raise ValueError(f"{name} must be an integer from 1 to {top}, got {value!r}")
    if config.humans > MAX_HUMANS_PER_FETCH * config.fetches:
        raise ValueError(
            f"humans must be at most {MAX_HUMANS_PER_FETCH} x fetches "
            f"(each Fetch's bay has room for {MAX_HUMANS_PER_FETCH} shelves of tools), "
            f"got humans={config.humans} with fetches={config.fetches}"
        )

"""Box Pushing's config, in a module of its own: the registry reads its defaults and validates
overrides without importing the simulation."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import ClassVar

from maopg.settings import setting
from maopg.tasks.box_pushing_grid.config import SIZES
from maopg.tasks.box_pushing_grid.config import Config as GridConfig
from maopg.tasks.config import SceneTaskConfig

BOX_SETTINGS = ("small_box_mass", "big_box_mass", "box_friction", "stall_distance", "stall_ticks")
"""The settings that decide whether one robot or two can move a box."""
ROBOT_SETTINGS: Mapping[str, Mapping[str, float]] = {
    "turtlebot": {},
    "vehicle": {"big_box_mass": 57.0},
    "diffbot": {"big_box_mass": 9.0, "stall_distance": 0.02},
}
"""Settings under which each built-in ground robot keeps the task cooperative — one robot does
not move the big box, two deliver it — measured by ``bench/analysis/box_pushing_robots.py``
(``docs/reference/tasks.md`` prints its table): the defaults are the Turtlebot's. The vehicle
pushes harder (two deliver 47 kg, but one alone creeps it 9 cm in 40 ticks), so its big box is
heavier; the differential drive is traction-limited and slower (two do not move 47 kg, and a
push of 9 kg makes less than the default stall distance a tick). Not applied by themselves: a
run sets them beside ``turtlebot_robot``, and one that does not is told so at its start
(:meth:`Config.advice`)."""


@dataclass(frozen=True)
class Config(SceneTaskConfig):
    """Box Pushing settings: the grid's layout and rewards (``box_pushing_grid``) in metres and
    newtons. The physical defaults are calibrated for the Turtlebot (see
    ``maopg/tasks/box_pushing/task.py`` for what they measure to)."""

    HAS_STATE: ClassVar[bool] = True

    size: int = setting(6, choices=SIZES)
    """Side of the square arena, in cells (the grid's sizes)."""
    agents: int = setting(2, choices=(2, 3))
    """Team size: the canonical two, or three (the third starts left of the middle of the
    second row, facing north, as on the grid)."""
    max_ticks: int = 100
    """The horizon: the grid's 100 ticks, five times the scripted episode on 10x10 (21 ticks;
    11 on 6x6); a timeout is a truncation, never a termination."""
    tick_seconds: float = 1.0
    """One tick moves a Turtlebot one cell (0.6 m at its 0.6 m/s), as a grid step does."""
    ROBOT_ROLES: ClassVar[Mapping[str, str]] = {"turtlebot_robot": "ground"}
    timestep: float = 0.01
    """10 ms: over random episodes a box and what touches it overlap at most 7.5 mm (at 20 ms:
    1.7 cm; two robots meeting head-on 1.4 cm, at 20 ms 3.3 cm), one robot holds a big box 15%
    lighter than the default (at 20 ms it turns it), and the differential drive's wheel servos
    turn it on the spot without rocking."""
    turtlebot_robot: str = "turtlebot"
    """The robots' registered name: any ground robot whose adapter can ``turn_to`` a heading."""
    cell_size: float = setting(0.6, ge=0.45, le=2.0)
    """Side of a grid cell (m): the Turtlebot (0.35 m across) passes a box (0.8 cell wide) in
    the next column with 0.18 m to spare, and two stand side by side below the big box."""
    small_box_mass: float = setting(3.0, gt=0.0)
    """kg: 18 N of floor friction, a tenth of what one Turtlebot pushes with."""
    big_box_mass: float = setting(47.0, gt=0.0)
    """kg: 277 N of floor friction, beyond one Turtlebot (180 N), within two (360 N); another
    robot's in :data:`ROBOT_SETTINGS`."""
    box_friction: float = setting(0.6, gt=0.0)
    """Sliding friction between a box and the floor (against robots, walls and other boxes a
    box slides at ``arena.BOX_SIDE_FRICTION``)."""
    big_box_reward: float = GridConfig.big_box_reward
    """Paid when the big box reaches the goal row."""
    small_box_reward: float = GridConfig.small_box_reward
    """Paid when a small box reaches the goal row."""
    penalty: float = GridConfig.penalty
    """Paid for a Push into a wall (started at the border facing out) and for a Push that
    stalls: against the big box alone, or anything else it cannot move."""
    step_reward: float = GridConfig.step_reward
    """Paid every tick."""
    stall_ticks: int = setting(2, ge=1)
    """A Push ends, penalised, after this many ticks in a row of less than ``stall_distance``
    of progress."""
    stall_distance: float = setting(0.05, gt=0.0)
    """Progress (m) along its heading under which a pushing robot's tick counts as stalled."""
    arrive_tol: float = setting(0.05, gt=0.0)
    """A robot within this distance of a waypoint (or of the end of its Push lane) is there."""
    face_tol: float = setting(0.1, gt=0.0)
    """A robot faces a heading within this angle (rad): where a GoTo or a turn ends."""
    turn_ticks: int = setting(3, ge=1)
    """A turn that has not reached its heading ends after this many ticks (a robot in the way)."""
    nav_slack_ticks: int = setting(4, ge=0)
    """A GoTo gives up this many ticks after its route's full-speed travel time."""

    def advice(self) -> list[str]:
        """With a robot other than the Turtlebot, the box settings still at the Turtlebot's:
        the robot's measured ones (:data:`ROBOT_SETTINGS`), or where to measure them."""
        if self.turtlebot_robot == "turtlebot":
            return []
        defaults = {f.name: f.default for f in fields(self)}
        tuned = ROBOT_SETTINGS.get(self.turtlebot_robot)
        if tuned is None:
            if any(getattr(self, k) != defaults[k] for k in BOX_SETTINGS):
                return []
            return [
                f"env.turtlebot_robot={self.turtlebot_robot}: the box masses and stall distance "
                "are the Turtlebot's; bench/analysis/box_pushing_robots.py measures whether one "
                "of your robots moves the big box and two deliver it"
            ]
        missing = [f"env.{k}={v:g}" for k, v in tuned.items() if getattr(self, k) == defaults[k]]
        if not missing:
            return []
        return [
            f"env.turtlebot_robot={self.turtlebot_robot}: at the Turtlebot's box settings the "
            f"task is not cooperative for it; its measured ones are {' '.join(missing)} "
            "(ROBOT_SETTINGS, docs/reference/tasks.md)"
        ]

    def validate(self) -> None:
        """The fields' own bounds and a ground robot (``ROBOT_ROLES``), then one that turns on
        the spot: Box Pushing's turns ask it to. (The robots are imported here: reading the
        settings, as ``--help`` does, builds none.)"""
        from maopg.sim.robots import GroundAdapter, get_robot, robots_of_role

        super().validate()
        adapter = get_robot(self.turtlebot_robot).adapter_class()
        if adapter.turn_to is GroundAdapter.turn_to:
            allowed = [
                name
                for name in robots_of_role("ground")
                if get_robot(name).adapter_class().turn_to is not GroundAdapter.turn_to
            ]
            raise ValueError(
                f"env.turtlebot_robot: {self.turtlebot_robot!r} cannot turn on the spot "
                f"({adapter.__name__} has no turn_to()); allowed: {', '.join(allowed)}"
            )

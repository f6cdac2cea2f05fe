"""The settings every task shares (``env.*``): :class:`TaskConfig`, and :class:`SceneTaskConfig`
for a task that ticks a MuJoCo scene. A task's own settings extend one of them
(:mod:`maopg.tasks.base` shows how); this module imports neither MuJoCo nor the task, so the
registry reads a task's settings, and the command line's ``--help`` lists them, without
building anything."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

from maopg.settings import Settings, setting
from maopg.sim.looks import APPEARANCES, OFF

MAX_IMAGE_SIZE = 4096
"""The largest camera image (px a side) a config accepts: far beyond what an observation needs,
and within what every GL implementation renders offscreen (OpenGL 3.3 guarantees 4096-pixel
render targets; Mesa's llvmpipe allows 16384)."""


@dataclass(frozen=True)
class TaskConfig(Settings):
    """Settings shared by every task; tasks extend it with their own fields. Command lines and
    config files write them ``env.NAME``."""

    PREFIX: ClassVar[str] = "env."

    max_ticks: int = setting(150, ge=1)
    """The horizon: an episode still running after this many ticks is truncated."""
    images: bool = False
    """Render each agent's camera into the observation."""
    image_size: int = setting(64, ge=1, le=MAX_IMAGE_SIZE)
    primitive: bool = False
    """Give agents one-tick primitive actions instead of options (end2end baseline)."""


@dataclass(frozen=True)
class SceneTaskConfig(TaskConfig):
    """The settings of a task that ticks a MuJoCo scene: a tick is a whole number of physics
    steps (the scene refuses anything else mid-episode, so the config refuses it up front)."""

    ROBOT_ROLES: ClassVar[Mapping[str, str]] = {}
    """The fields that name a registered robot, each with the role (``ground``, ``drone``,
    ``arm``: :data:`maopg.sim.robots.ROLES`) its robot must play: a robot of another role is
    refused when the config is made, naming the setting and the robots allowed there."""

    tick_seconds: float = setting(1.0, gt=0.0)
    """Simulated time of one tick, one low-level step (s)."""
    timestep: float = setting(0.002, gt=0.0)
    """Physics step (s)."""
    appearance: str = setting(OFF, choices=APPEARANCES)
    """How the scene looks, drawn per episode from its seed (domain randomisation; physics and
    rules never change): ``off`` as built; ``light`` colours and light intensities; ``full``
    textures, lights, camera jitter and distractors too; ``heldout`` a look never drawn in
    training; ``dusk``, ``neon``, ``glare`` fixed held-out looks (:mod:`maopg.sim.looks`)."""

    def validate(self) -> None:
        super().validate()
        steps = round(self.tick_seconds / self.timestep)
        if steps < 1 or abs(steps * self.timestep - self.tick_seconds) > 1e-6 * max(
            1.0, self.tick_seconds
        ):
            raise ValueError(
                f"env.tick_seconds={self.tick_seconds} is not a whole number of "
                f"env.timestep={self.timestep} physics steps"
            )
        if self.ROBOT_ROLES:  # the robot registry, and MuJoCo, only for a task that has robots
            from maopg.sim.robots import require_role

            for field, role in self.ROBOT_ROLES.items():
                require_role(self.PREFIX + field, getattr(self, field), role)

"""The settings every task shares (``env.*``): :class:`TaskConfig`, and :class:`SceneTaskConfig`
for a task that ticks a MuJoCo scene. A task's own settings extend one of them
(:mod:`maopg.tasks.base` shows how); this module imports neither MuJoCo nor the task, so the
registry reads a task's settings, and the command line's ``--help`` lists them, without
building anything."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

from maopg.settings import Settings, field_bounds, setting
from maopg.sim.channels import parse_channels
from maopg.sim.looks import APPEARANCES, OFF
from maopg.tasks.camera_settings import CameraMount, role_values, value_for

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

    HAS_STATE: ClassVar[bool] = False
    """Whether the task reports a global state (:meth:`maopg.tasks.base.Task.global_state`), for the
    critics that take one: known from the settings' class, so a run that needs it is refused
    before anything is built."""

    def advice(self) -> list[str]:
        """What a run says at its start about these settings: a combination that runs, but
        that behaves otherwise than a user likely means (none by default)."""
        return []


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
    textures, lights, camera jitter and distractors too; ``heldout`` colours, textures and
    lights never drawn in training; ``mounts`` full's looks with the cameras moved further on
    their mounts than training does; ``dusk``, ``neon``, ``glare`` fixed held-out looks
    (:mod:`maopg.sim.looks`)."""
    appearance_distractors: bool = True
    """Whether the looks that stand distractor objects by the walls (full, heldout, mounts
    and the presets) do: false draws the same looks without them (nothing else changes)."""
    camera_channels: str = "rgb"
    """What each camera image holds, any of rgb, depth (metres) and seg (class ids) joined by
    '+' (rgb+depth+seg), stacked in that order. One set for the whole team: every agent's
    image travels in one array, and a rollout banks them together. Resolution is the run's
    image_size, for the same reason."""
    camera_fovy: float | str | None = setting(None, gt=0.0, lt=180.0)
    """Vertical field of view of the robots' cameras (degrees), for every robot (90) or per
    role (ground:70,drone:110; an entry without a role sets the others); null: each robot's
    own."""
    camera_offset: tuple[float, float, float] | str = setting((0.0, 0.0, 0.0), ge=-1.0, le=1.0)
    """Moves each robot's camera on its mount, metres along the camera's own axes (x right,
    y up, z backward, away from what it looks at): [0, 0.1, 0] for every robot, or per role
    (drone:0 0 -0.05). Within a metre of the mount on each axis: further, a camera leaves the
    robot it rides on, into walls and other robots."""
    camera_rotation: tuple[float, float, float] | str = setting(
        (0.0, 0.0, 0.0), ge=-180.0, le=180.0
    )
    """Turns each robot's camera on its mount, degrees about its own x (tilts the view up),
    then y (turns it left), then z (rolls it) axis: for every robot, or per role (ground:-10
    0 0); each angle within ±180."""

    CAMERA_SIZES: ClassVar[Mapping[str, int]] = {
        "camera_fovy": 1,
        "camera_offset": 3,
        "camera_rotation": 3,
    }
    """The per-role camera settings (:mod:`maopg.tasks.camera_settings`) and the numbers of
    one value."""

    def camera_roles(self) -> tuple[str, ...]:
        """The roles a per-role camera setting may name: those of the task's robot fields
        (``ROBOT_ROLES``), or every role where the task declares none."""
        if self.ROBOT_ROLES:
            return tuple(dict.fromkeys(self.ROBOT_ROLES.values()))
        from maopg.sim.robots import ROLES

        return tuple(ROLES)

    def camera_mount(self, role: str) -> CameraMount:
        """What the camera settings give a robot of ``role``."""
        values = {
            name: value_for(
                role_values(self.PREFIX + name, getattr(self, name), size, self.camera_roles()),
                role,
            )
            for name, size in self.CAMERA_SIZES.items()
        }
        return CameraMount(
            values["camera_fovy"],  # type: ignore[arg-type]  (one number)
            values["camera_offset"] or (0.0, 0.0, 0.0),  # type: ignore[arg-type]  (three)
            values["camera_rotation"] or (0.0, 0.0, 0.0),  # type: ignore[arg-type]
        )

    def validate(self) -> None:
        super().validate()
        parse_channels(self.camera_channels, self.PREFIX + "camera_channels")
        for name, size in self.CAMERA_SIZES.items():
            value = getattr(self, name)
            if not isinstance(value, str):
                continue  # a number or a tuple: checked by its kind and bounds
            setting_name = self.PREFIX + name
            bounds = field_bounds(type(self), name)
            for number in role_values(setting_name, value, size, self.camera_roles()).values():
                problem = bounds.problem(number)
                if problem:
                    raise ValueError(f"{setting_name} {problem}, got {value!r}")
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

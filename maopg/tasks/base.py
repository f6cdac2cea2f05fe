"""What a task implements so that :class:`maopg.env.OptionEnv` can run it.

A task owns a compiled MuJoCo scene, its robots' adapters, its option sets and its rules
(reward, termination, observations). It knows nothing about termination *strategies* or
learners: the option environment decides who chooses when, and calls these hooks. A user's own
task subclasses :class:`Task`, fills in the abstract methods, registers itself with
:func:`maopg.tasks.register_task`, and gets the strategies (those that idle or interrupt agents
with a :meth:`Task.hold` of its own: :attr:`Task.strategies`), the PettingZoo adapter, every
learner and the registry-wide contract test (``tests/tasks/test_contract.py``) for free.

Its options are written against protocols of the options layer (:mod:`maopg.options.base`),
which the task implements; observation vectors follow the task's named
:class:`~maopg.tasks.layout.ObsLayout` per agent.

A task's settings are a frozen dataclass deriving from :class:`TaskConfig` (or
:class:`SceneTaskConfig`), a :class:`maopg.settings.Settings`: each field declares its kind by
its annotation and its bounds with :func:`maopg.settings.setting`, checked once when the config
is made, before anything is built::

    @dataclass(frozen=True)
    class Config(SceneTaskConfig):
        max_ticks: int = 200                       # keeps TaskConfig's bound (>= 1)
        robots: int = setting(2, ge=1, le=8)       # a team size
        spot: tuple[float, float] = (1.0, 2.0)     # two numbers; JSON lists become tuples
        step_reward: float = -1.0                  # any finite number

so ``env.robots=0`` fails with ``env.robots must be >= 1, got 0``. Relations between fields go
in ``validate()`` (call ``super().validate()`` first); a check that needs the task's world (a
position inside the arena) belongs in the task's constructor, before it compiles its scene.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from functools import cached_property
from typing import Any, ClassVar

import mujoco
import numpy as np

from maopg.options.base import Option, Strategy
from maopg.sim.appearance import Appearance, Surfaces
from maopg.sim.channels import RGB, ImageChannels, parse_channels
from maopg.sim.looks import OFF
from maopg.sim.mounts import Mount, mount_camera
from maopg.sim.render import CameraRenderer, depth_range
from maopg.sim.robots import RobotAdapter, role_of
from maopg.sim.scene import Scene
from maopg.sim.segmentation import ClassTable, class_table
from maopg.tasks.config import (  # noqa: F401  (a task module finds its config's bases here too)
    MAX_IMAGE_SIZE,
    SceneTaskConfig,
    TaskConfig,
)
from maopg.tasks.layout import ObsLayout


class Task(ABC):
    """A cooperative multi-robot task at the tick level."""

    name: str
    tick_seconds: float
    config: TaskConfig
    behaviour_version: ClassVar[int] = 1
    """The version of what the task does, tick by tick: raise it with any change to its
    trajectories, observations, rewards or images (its options, robots, scene or scripted
    policy), so that evaluations cached for the old behaviour are made again
    (:mod:`maopg.experiment.studies.cache`; ``tests/test_behaviour_versions.py`` fails for a
    built-in task whose reference trajectory changed while its version did not)."""

    strategies: ClassVar[frozenset[Strategy] | None] = None
    """The termination strategies the task runs under (docs/DESIGN.md §3), checked before a
    run or an evaluation builds it and wherever an environment is built over it
    (:func:`require_strategy`). ``None`` (the default): derived from the class
    (:meth:`supported_strategies`): every strategy where it has a :meth:`hold` of its own,
    else ``continue`` and ``primitive`` only — ``all`` idles the agents that finished with it,
    and ``any`` stops the interrupted options with it (the default
    :meth:`maopg.options.base.Option.interrupt`). A task declares them where that does not fit:
    one whose options all interrupt without ``hold()`` adds ``any``; one whose :meth:`options`
    ignore ``config.primitive`` (the one-tick primitive actions of ``primitive``) leaves that
    out."""

    @classmethod
    def supported_strategies(cls) -> frozenset[Strategy]:
        """:attr:`strategies`, or those derived from the class where it declares none."""
        if cls.strategies is not None:
            return frozenset(Strategy(s) for s in cls.strategies)
        if cls.hold is not Task.hold:
            return frozenset(Strategy)
        return frozenset({Strategy.CONTINUE, Strategy.PRIMITIVE})

    # ----------------------------------------------------------------- static description
    @property
    @abstractmethod
    def agent_names(self) -> tuple[str, ...]:
        """Agent names, in the order every per-agent array uses."""

    @abstractmethod
    def robot_of(self, agent: int) -> str:
        """Registry name of the robot the agent drives."""

    @abstractmethod
    def options(self, agent: int) -> Sequence[Option[Any]]:
        """The agent's option set (primitive actions when ``config.primitive``)."""

    @abstractmethod
    def observation_layout(self, agent: int) -> ObsLayout:
        """The named fields of the agent's observation vector."""

    def vector_size(self, agent: int) -> int:
        """Length of the agent's observation vector."""
        return self.observation_layout(agent).size

    # ----------------------------------------------------------------- dynamics
    @abstractmethod
    def reset(self, seed: int) -> None:
        """Start a new episode: physics, task state and every random stream from ``seed``."""

    def hold(self, agent: int) -> None:
        """Command the agent's robot to stay put this tick: how an agent that finished idles
        under ``all`` (sync-wait), and how an option that ``any`` (sync-cut) interrupts stops
        by default. A task without it runs under ``continue`` and ``primitive``
        (:attr:`strategies`)."""
        raise NotImplementedError(
            f"task {getattr(self, 'name', type(self).__name__)!r} has no hold(): it cannot "
            "idle or interrupt an agent (strategies 'all' and 'any')"
        )

    def draw_appearance(self, seed: int) -> None:  # noqa: B027 (optional hook)
        """Show the episode's look, drawn from ``seed`` (``env.appearance``); the option
        environment calls it right after :meth:`reset` with the same seed. A task without a
        scene has none."""

    @abstractmethod
    def tick(self) -> float:
        """Advance one tick: physics with the commands given this tick, then the rules.

        Returns the shared reward of this tick.
        """

    @property
    @abstractmethod
    def ticks(self) -> int:
        """Ticks since reset."""

    @abstractmethod
    def terminated(self) -> bool:
        """The task reached a terminal state."""

    def solved(self) -> bool:
        """Whether the episode counts as a success (defaults to termination)."""
        return self.terminated()

    def truncated(self) -> bool:
        """The task's own time limit ended the episode before ``max_ticks`` (a wrapped simulator
        with a horizon of its own); the learner then bootstraps, as at ``max_ticks``."""
        return False

    # ----------------------------------------------------------------- observations
    @abstractmethod
    def observe(self, agent: int) -> np.ndarray:
        """A fresh float32 observation vector of the agent (called when its option ends), laid
        out as :meth:`observation_layout`."""

    def global_state_size(self) -> int | None:
        """Length of :meth:`global_state`; ``None`` for a task without one (its settings'
        ``HAS_STATE`` says which)."""
        return None

    def global_state(self) -> np.ndarray | None:
        """The task's global state now (float32, :meth:`global_state_size` long), for a critic
        that takes one (``maciaicc.critic=state``); no policy reads it. ``None`` by default."""
        return None

    def render(self, agents: Sequence[int], out: np.ndarray) -> None:
        """Render the listed agents' cameras into ``out[agent]`` (``[N, H, W, planes]`` of
        :meth:`image_channels`; colour only: uint8 ``[N, H, W, 3]``)."""
        raise NotImplementedError(f"task {self.name!r} has no camera observations")

    def image_channels(self) -> ImageChannels:
        """What :meth:`render` puts in each image (:mod:`maopg.sim.channels`): colour only,
        unless the task renders more."""
        return RGB

    def describe(self) -> dict[str, object]:
        """Task state for logs and video overlays (human stage, jar levels, ...)."""
        return {}

    def video_frame(self) -> np.ndarray | None:
        """A picture of the current state for rollout videos (uint8 ``[H, W, 3]``), or ``None``.

        A task without a MuJoCo scene (a 2-D simulator of the user's, a PettingZoo game) may
        draw itself here; without it its video shows the state panel alone. Scene tasks film
        their overview camera instead."""
        return None

    def close(self) -> None:  # noqa: B027 (optional hook)
        """Release renderers and other resources."""


def require_strategy(
    cls: type[Task], task: str, strategy: str, *, method: str | None = None
) -> None:
    """Refuse, in one line, a ``strategy`` the task class ``cls`` registered as ``task`` does
    not run under (:meth:`Task.supported_strategies`), naming the ``method`` that asked for it
    when one did: before a run or an evaluation builds anything, rather than a traceback at
    its first idle tick."""
    supported = cls.supported_strategies()
    if strategy in supported:
        return
    asked = f"method {method!r} (strategy {strategy!r})" if method else f"strategy {strategy!r}"
    names = ", ".join(s.value for s in Strategy if s in supported) or "none"
    raise ValueError(f"task {task!r} does not support {asked}; it supports: {names}")


class SceneTask(Task):
    """A task whose agents are the robots of one compiled :class:`~maopg.sim.scene.Scene`.

    Subclasses set ``self.config``, then ``self.scene``, then ``self.agent_robots`` (adapters
    in agent order); this class then provides holding, camera observations, the looks of
    ``env.appearance`` and cleanup.
    Setting ``agent_robots`` mounts the robots' cameras as the config's camera settings say
    (``env.camera_fovy``, ``camera_offset``, ``camera_rotation``, per robot role:
    :mod:`maopg.sim.mounts`), so every scene task, a user's included, gets them without code
    of its own; at their defaults the model is left as compiled. The renderer is created on
    first use, so building a task in a parent process never creates a GL context (a
    ``fork``ed child would hang on it, docs/DESIGN.md §2).

    Its scene builder is given ``appearance=config.appearance``, which compiles in what the
    looks need (:mod:`maopg.sim.appearance`); :attr:`surfaces` names the furniture they may
    restyle.
    """

    scene: Scene
    _renderer: CameraRenderer | None = None
    _agent_robots: tuple[RobotAdapter, ...] = ()
    _mounts: dict[int, Mount] | None = None
    """Each re-mounted camera's mount as compiled."""
    surfaces: ClassVar[Surfaces] = Surfaces()
    """The geoms ``env.appearance`` restyles (floors and walls found by their usual names by
    default; a task adds its furniture, never what its rules or display colour)."""
    _appearance: Appearance | None = None

    prop_classes: ClassVar[Mapping[str, str]] = {}
    """The segmentation classes of the task's props: each prop kind (a prop body's name
    without instance number or attachment prefix: ``jar0/jar`` → ``jar``) → its class
    (:mod:`maopg.sim.segmentation`). The classes follow ``background, floor, wall, robot,
    distractor`` in the order of this mapping's values; a kind not in it is a class of its
    own, after them in name order."""

    @property
    def agent_robots(self) -> tuple[RobotAdapter, ...]:
        """The agents' robot adapters, in agent order."""
        return self._agent_robots

    @agent_robots.setter
    def agent_robots(self, robots: Sequence[RobotAdapter]) -> None:
        self._agent_robots = tuple(robots)
        self._mount_cameras()

    def _mount_cameras(self) -> None:
        """Apply the config's camera settings to the robots' cameras (always from the mount
        the model was compiled with, so doing it again changes nothing)."""
        config = getattr(self, "config", None)
        if config is None:
            raise AttributeError(
                f"{type(self).__name__}: set self.config before self.agent_robots (the robots' "
                "cameras are mounted as its camera settings say)"
            )
        if not isinstance(config, SceneTaskConfig):
            return
        model = self.scene.model
        if self._mounts is None:
            self._mounts = {}
        moved = False
        for robot in self._agent_robots:
            mount = config.camera_mount(role_of(type(robot)))
            if mount.as_compiled:
                continue  # not a bit of the model changes
            moved = True
            home = self._mounts.setdefault(robot.camera_id, Mount.of(model, robot.camera_id))
            mount_camera(
                model,
                robot.camera_id,
                home,
                fovy=mount.fovy,
                offset=mount.offset,
                rotation=mount.rotation,
            )
        if moved:  # the cameras' world poses now, not at the next step
            mujoco.mj_camlight(model, self.scene.data)

    def draw_appearance(self, seed: int) -> None:
        appearance = getattr(self.config, "appearance", OFF)
        if appearance == OFF:
            return
        if self._appearance is None:  # after building: the cameras as the task mounted them
            cameras = [robot.camera_id for robot in self.agent_robots]
            scene = self.scene
            self._appearance = Appearance(
                scene.model,
                scene.data,
                tuple(scene.robots),
                self.surfaces,
                cameras,
                start=scene.start_state(),
                distractors=getattr(self.config, "appearance_distractors", True),
            )
        self._appearance.show(appearance, seed)

    def hold(self, agent: int) -> None:
        self.agent_robots[agent].hold()

    @cached_property
    def segmentation(self) -> ClassTable:
        """The segmentation class of every geom of the scene (:mod:`maopg.sim.segmentation`),
        made once per build."""
        roots = [robot.root_body_id for robot in self.scene.robots.values()]
        return class_table(self.scene.model, roots, self.prop_classes)

    def image_channels(self) -> ImageChannels:
        config = self.config
        names = (
            parse_channels(config.camera_channels)
            if isinstance(config, SceneTaskConfig)
            else RGB.names
        )
        return ImageChannels(
            names,
            depth_range(self.scene.model) if "depth" in names else None,
            self.segmentation.classes if "seg" in names else (),
        )

    def camera_renderer(self, height: int, width: int) -> CameraRenderer:
        """A renderer of the robots' cameras giving :meth:`image_channels` (the observations'
        and the video's tiles)."""
        channels = self.image_channels()
        classes = self.segmentation if "seg" in channels.names else None
        return CameraRenderer(self.scene.model, height, width, channels=channels, classes=classes)

    def render(self, agents: Sequence[int], out: np.ndarray) -> None:
        if self._renderer is None:
            size = self.config.image_size
            self._renderer = self.camera_renderer(size, size)
        for i in agents:
            camera = self.agent_robots[i].camera_id
            self._renderer.render(self.scene.data, [camera], out=out[i : i + 1])

    def labels(self) -> list[tuple[str, np.ndarray]]:
        """What a video labels on its overview: ``(text, world xyz)`` pairs at the current
        state; by default every agent's name at its robot's root body. A task adds its own
        landmarks (Water Filling: the jars' indices) by extending this list, so the video
        knows no task by name. Only a scene task has world points to label."""
        xpos = self.scene.data.xpos
        return [
            (name, xpos[robot.root_body_id].copy())
            for name, robot in zip(self.agent_names, self.agent_robots, strict=True)
        ]

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

"""What a task implements so that :class:`maopg.env.OptionEnv` can run it.

A task owns a compiled MuJoCo scene, its robots' adapters, its option sets and its rules
(reward, termination, observations). It knows nothing about termination *strategies* or
learners: the option environment decides who chooses when, and calls these hooks. A user's own
task subclasses :class:`Task`, fills in the abstract methods, registers itself with
:func:`maopg.tasks.register_task`, and gets every strategy, the PettingZoo adapter, every learner
and the registry-wide contract test (``tests/tasks/test_contract.py``) for free.

Its options are written against protocols of the options layer (:mod:`maopg.options.base`),
which the task implements; observation vectors follow the task's named
:class:`~maopg.tasks.layout.ObsLayout` per agent.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from maopg.options.base import Option
from maopg.sim.render import CameraRenderer
from maopg.sim.robots.base import RobotAdapter
from maopg.sim.scene import Scene
from maopg.tasks.layout import ObsLayout


@dataclass(frozen=True)
class TaskConfig:
    """Settings shared by every task; tasks extend it with their own fields."""

    max_ticks: int = 150
    images: bool = False
    """Render each agent's camera into the observation."""
    image_size: int = 64
    primitive: bool = False
    """Give agents one-tick primitive actions instead of options (end2end baseline)."""


class Task(ABC):
    """A cooperative multi-robot task at the tick level."""

    name: str
    tick_seconds: float
    config: TaskConfig

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

    @abstractmethod
    def hold(self, agent: int) -> None:
        """Command the agent's robot to stay put this tick (idle / interrupted agents)."""

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

    def render(self, agents: Sequence[int], out: np.ndarray) -> None:
        """Render the listed agents' cameras into ``out[agent]`` (uint8 ``[N, H, W, 3]``)."""
        raise NotImplementedError(f"task {self.name!r} has no camera observations")

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


class SceneTask(Task):
    """A task whose agents are the robots of one compiled :class:`~maopg.sim.scene.Scene`.

    Subclasses set ``self.scene`` and ``self.agent_robots`` (adapters in agent order); this
    class then provides holding, camera observations and cleanup. The renderer is created on
    first use, so building a task in a parent process never creates a GL context (a ``fork``ed
    child would hang on it, docs/DESIGN.md §2).
    """

    scene: Scene
    agent_robots: Sequence[RobotAdapter]
    _renderer: CameraRenderer | None = None

    def hold(self, agent: int) -> None:
        self.agent_robots[agent].hold()

    def render(self, agents: Sequence[int], out: np.ndarray) -> None:
        if self._renderer is None:
            size = self.config.image_size
            self._renderer = CameraRenderer(self.scene.model, size, size)
        for i in agents:
            camera = self.agent_robots[i].camera_id
            self._renderer.render(self.scene.data, [camera], out=out[i : i + 1])

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

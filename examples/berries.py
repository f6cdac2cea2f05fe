"""A user's own task, outside the package: two pickers harvest berries in a 2-D field.

No MuJoCo scene: the simulator is a few lines of numpy, as a user's existing macro-action
simulator would be, wrapped in a :class:`maopg.tasks.Task`. Importing this module registers it,
so any command line can use it::

    python -m train --import examples.berries --task berries --method async
    python -m eval evaluate --import examples.berries --reference scripted --task berries

(``--import`` is remembered by the run: ``--resume`` and ``eval evaluate --checkpoint`` import
it again.) It also registers a study of its own, which reproduces a small comparison on it::

    python -m eval reproduce --import examples.berries --study berries
 The rules: four bushes ripen at random (each tick an unripe bush ripens with
probability ``ripen_prob``); a picker's option ``Harvest(b)`` walks to bush ``b`` at one metre
per tick — so options last as long as the walk, and the two pickers decide asynchronously —
and harvests it on arrival: +10 if it is ripe (it is then bare again), nothing otherwise. Every
tick costs ``step_reward``. Both pickers see where they are and which bushes are ripe.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from maopg.experiment.studies import Study, StudyTask, register_study
from maopg.options.base import Execution, Option
from maopg.settings import setting
from maopg.tasks import ObsLayout, Task, TaskConfig, register_task
from maopg.tasks.scripting import DecisionView

BUSHES = ((1.0, 1.0), (9.0, 1.0), (1.0, 9.0), (9.0, 9.0))
PICKERS = ("picker0", "picker1")
STARTS = ((5.0, 4.0), (5.0, 6.0))


@dataclass(frozen=True)
class BerryConfig(TaskConfig):
    """The field's settings (``env.KEY=VALUE`` on the command line)."""

    max_ticks: int = 60
    ripen_prob: float = setting(0.08, ge=0.0, le=1.0)
    """Chance per tick that a bush ripens (a probability, so its bounds are declared)."""
    step_reward: float = -0.1
    harvest_reward: float = 10.0


class Harvest(Option["BerryField"]):
    """Walk to bush ``bush`` (one metre per tick) and harvest it on arrival."""

    def __init__(self, bush: int) -> None:
        self.bush = bush
        self.name = f"Harvest({bush})"

    def step(self, task: BerryField, ex: Execution) -> None:
        task.walk(ex.agent, BUSHES[self.bush])

    def done(self, task: BerryField, ex: Execution) -> bool:
        return task.harvest_if_there(ex.agent, self.bush)


class BerryField(Task):
    """The task (see the module docstring)."""

    name = "berries"
    tick_seconds = 1.0

    def __init__(self, config: BerryConfig | None = None) -> None:
        self.config = config or BerryConfig()
        self._options = tuple(Harvest(b) for b in range(len(BUSHES)))
        self._layout = ObsLayout.of(position=2, ripe=len(BUSHES))
        self.reset(0)

    @property
    def agent_names(self) -> tuple[str, ...]:
        return PICKERS

    def robot_of(self, agent: int) -> str:
        return "point"  # no MuJoCo robot: a point that walks

    def options(self, agent: int) -> Sequence[Option[BerryField]]:
        return self._options

    def observation_layout(self, agent: int) -> ObsLayout:
        return self._layout

    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.position = np.array(STARTS, dtype=float)
        self.ripe = np.zeros(len(BUSHES), dtype=bool)
        self._reward = 0.0
        self._ticks = 0

    def hold(self, agent: int) -> None:
        """Standing still needs no command."""

    def walk(self, agent: int, target: Sequence[float]) -> None:
        delta = np.asarray(target) - self.position[agent]
        distance = float(np.hypot(*delta))
        self.position[agent] += delta if distance <= 1.0 else delta / distance

    def harvest_if_there(self, agent: int, bush: int) -> bool:
        """True once the picker stands at the bush (and harvests it, if ripe)."""
        if math.dist(self.position[agent], BUSHES[bush]) > 1e-9:
            return False
        if self.ripe[bush]:
            self.ripe[bush] = False
            self._reward += self.config.harvest_reward
        return True

    def tick(self) -> float:
        reward, self._reward = self._reward + self.config.step_reward, 0.0
        self.ripe |= self.rng.random(len(BUSHES)) < self.config.ripen_prob
        self._ticks += 1
        return reward

    @property
    def ticks(self) -> int:
        return self._ticks

    def terminated(self) -> bool:
        return False  # the field never runs out: episodes end at max_ticks

    def observe(self, agent: int) -> np.ndarray:
        obs = self._layout.zeros()
        obs[self._layout["position"]] = self.position[agent] / 10.0
        obs[self._layout["ripe"]] = self.ripe
        return obs

    def describe(self) -> dict[str, object]:
        return {"ripe": self.ripe.tolist(), "pickers": self.position.round(1).tolist()}

    def video_frame(self) -> np.ndarray:
        """A top view: bushes green when ripe, pickers as white squares."""
        frame = np.full((200, 200, 3), 40, np.uint8)
        for (x, y), ripe in zip(BUSHES, self.ripe, strict=True):
            frame[_px(y) - 6 : _px(y) + 6, _px(x) - 6 : _px(x) + 6] = (60, 200, 60) if ripe else 90
        for x, y in self.position:
            frame[_px(y) - 4 : _px(y) + 4, _px(x) - 4 : _px(x) + 4] = 235
        return frame


def _px(metres: float) -> int:
    return int(10 + metres * 18)


def scripted_policy(config: BerryConfig):
    """Each choosing picker walks to the nearest ripe bush the other is not heading for (any
    nearest bush when none is ripe)."""
    layout = ObsLayout.of(position=2, ripe=len(BUSHES))
    bushes = np.array(BUSHES)

    def act(point: DecisionView) -> np.ndarray:
        joint = point.running.copy()
        for agent in np.flatnonzero(point.choosing):
            obs = layout.split(point.vectors[agent])
            distance = np.hypot(*(bushes - obs["position"] * 10.0).T)
            taken = [joint[o] for o in range(len(PICKERS)) if o != agent]
            wanted = obs["ripe"] > 0
            wanted[[b for b in taken if b >= 0]] = False
            joint[agent] = int(np.argmin(np.where(wanted, distance, distance + 100.0)))
        return joint

    return act


register_task(
    "berries",
    BerryField,
    config=BerryConfig,
    scripted=scripted_policy,
    train_defaults={"batch_ticks": 400, "total_samples": 20_000, "images": False},
)
register_study(
    "berries",
    lambda: Study(
        "berries",
        "the paper's method against its partially centralized variant on the berry field",
        # Near the scripted pickers' 92 (python -m eval evaluate --import examples.berries
        # --reference scripted --task berries --episodes 20).
        (StudyTask("berries", (0, 1, 2), threshold=85.0),),
        ("async", "partial"),
        normalised=True,
    ),
)

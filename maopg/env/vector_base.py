"""What every vector-environment backend is built from: the picklable recipe of one environment
(:class:`EnvConfig`), the :class:`VectorEnv` protocol and its in-process implementation
(:class:`LocalVectorEnv`), the seed of each episode, the fingerprint that verifies a replay,
and the bootstrap of a worker in another process (:func:`worker_envs`).

The backends themselves and the seeded, resumable wrapper are in :mod:`maopg.env.vector`; a
backend in a module of its own (:mod:`maopg.env.ray_backend`) needs only this one.
"""

from __future__ import annotations

import dataclasses
import hashlib
import pickle
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.env.option_env import OptionEnv
from maopg.plugins import load_plugins
from maopg.sim.robots import RobotSpec, get_robot, register_robot, robot_names
from maopg.tasks.registry import register_task, task_entry, task_names


def split_envs(num_envs: int, parts: int) -> list[list[int]]:
    """Environments ``0..num_envs-1`` in at most ``parts`` contiguous groups of near-equal size
    (one per thread, process or actor; never an empty one)."""
    return [[int(e) for e in g] for g in np.array_split(np.arange(num_envs), min(parts, num_envs))]


def episode_seed(run_seed: int, env_index: int, episode: int) -> int:
    """The reset seed of episode ``episode`` of environment ``env_index`` in run ``run_seed``."""
    return int(np.random.SeedSequence([run_seed, env_index, episode]).generate_state(1)[0])


@dataclass(frozen=True)
class EnvConfig:
    """Everything needed to build one environment in any process (picklable)."""

    task: str
    strategy: str
    images: bool = False
    image_size: int = 64
    gamma: float = 0.99
    overrides: Mapping[str, Any] = field(default_factory=dict)

    def make(self, seed: int) -> OptionEnv:
        from maopg.env import make_env

        return make_env(
            self.task,
            self.strategy,
            seed=seed,
            images=self.images,
            image_size=self.image_size,
            gamma=self.gamma,
            overrides=dict(self.overrides) or None,
        )


@dataclass
class StepResult:
    """One environment's answer to a step: the point to act on next, and the episode's final
    point when the step ended the episode (the environment has then already been reset)."""

    point: DecisionPoint
    final: DecisionPoint | None = None

    @property
    def outcome(self) -> DecisionPoint:
        """The point that reports this step's reward, duration and termination."""
        return self.final if self.final is not None else self.point


class VectorEnv(Protocol):
    """What a backend does for :class:`SeededVectorEnv`; every list is in environment order.
    Every point it returns is a new object that owns its arrays (:meth:`DecisionPoint.copy`, or
    unpickled from a worker): learners keep them across steps without copying."""

    num_envs: int

    def spec(self) -> EnvSpec: ...

    def reset(self, seeds: Sequence[int]) -> list[DecisionPoint]:
        """Reset environment ``e`` with ``seeds[e]``."""
        ...

    def step(self, joints: np.ndarray, next_seeds: Sequence[int]) -> list[StepResult]:
        """Apply ``joints[e]``; an episode that ends is reset at once with ``next_seeds[e]``."""
        ...

    def replay(
        self, seeds: Sequence[int], actions: Sequence[Sequence[np.ndarray]]
    ) -> list[DecisionPoint]:
        """Reset environment ``e`` with ``seeds[e]`` and re-apply its joint options."""
        ...

    def close(self) -> None: ...


class LocalVectorEnv:
    """Environments in this process (also the body of each worker of the process backend)."""

    def __init__(self, config: EnvConfig, env_indices: Sequence[int], run_seed: int) -> None:
        self.envs = [config.make(episode_seed(run_seed, e, 0)) for e in env_indices]
        self.num_envs = len(self.envs)

    def spec(self) -> EnvSpec:
        return self.envs[0].spec

    def reset(self, seeds: Sequence[int]) -> list[DecisionPoint]:
        return [env.reset(seed=s).copy() for env, s in zip(self.envs, seeds, strict=True)]

    def step(self, joints: np.ndarray, next_seeds: Sequence[int]) -> list[StepResult]:
        results = []
        for env, joint, seed in zip(self.envs, joints, next_seeds, strict=True):
            point = env.step(joint).copy()
            if point.done:
                results.append(StepResult(env.reset(seed=seed).copy(), point))
            else:
                results.append(StepResult(point))
        return results

    def replay(
        self, seeds: Sequence[int], actions: Sequence[Sequence[np.ndarray]]
    ) -> list[DecisionPoint]:
        points = []
        for env, seed, joints in zip(self.envs, seeds, actions, strict=True):
            point = env.reset(seed=seed)
            for joint in joints:
                point = env.step(joint)
                if point.done:
                    raise RuntimeError("replayed actions ended the episode: log is inconsistent")
            points.append(point.copy())
        return points

    def close(self) -> None:
        for env in self.envs:
            env.close()


class SplitVectorEnv(ABC):
    """A backend that serves every call by giving each of its groups of environments its slice
    of the per-environment arguments (:meth:`_split`) and concatenating the answers."""

    @abstractmethod
    def _split(self, call: str, *per_env_args: Sequence[Any]) -> list[Any]:
        """``LocalVectorEnv.<call>`` on every group with its slices, answers in env order."""

    def reset(self, seeds: Sequence[int]) -> list[DecisionPoint]:
        return self._split("reset", seeds)

    def step(self, joints: np.ndarray, next_seeds: Sequence[int]) -> list[StepResult]:
        return self._split("step", joints, next_seeds)

    def replay(
        self, seeds: Sequence[int], actions: Sequence[Sequence[np.ndarray]]
    ) -> list[DecisionPoint]:
        return self._split("replay", seeds, actions)


def registrations(task: str) -> bytes:
    """What a worker needs of the parent's registries, pickled: classes travel by module and
    name, so the worker unpickles them only after importing its plugins (a plugin loaded from
    a file is a module only once imported). An entry that does not pickle (a lambda) is left
    out: the worker then relies on the plugins alone."""
    entry = task_entry(task)
    fields = {f.name: getattr(entry, f.name) for f in dataclasses.fields(entry)}
    fields = {k: dict(v) if isinstance(v, Mapping) else v for k, v in fields.items()}
    picklable = []
    for item in (fields, *(get_robot(name) for name in robot_names())):
        try:
            picklable.append(pickle.dumps(item))
        except (pickle.PicklingError, AttributeError, TypeError):
            continue
    return pickle.dumps(picklable)


def _adopt(registered: bytes) -> None:
    """Register in this (spawned) process what the parent registered and this one lacks."""
    for item in map(pickle.loads, pickle.loads(registered)):
        if isinstance(item, RobotSpec):
            if item.name not in robot_names():
                register_robot(item.name, item.mjcf, item.adapter, item.constants)
        elif item["name"] not in task_names():
            register_task(**item)


def worker_envs(
    config: EnvConfig,
    env_indices: Sequence[int],
    run_seed: int,
    registered: bytes,
    plugins: Sequence[str] = (),
) -> LocalVectorEnv:
    """The environments of a worker in another process (spawned, or a Ray actor on any
    machine): the parent's plugins (``plugins``, and ``MAOPG_PLUGINS`` where inherited), then
    whatever else it registered (:func:`registrations`), then the environments."""
    import maopg  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

    load_plugins(plugins)
    _adopt(registered)
    return LocalVectorEnv(config, env_indices, run_seed)


def digest(point: DecisionPoint) -> str:
    """Fingerprint of a decision point's observations and condition (to verify a replay)."""
    sha = hashlib.sha256()
    for array in (*point.vectors, point.choosing, point.running, *point.available):
        sha.update(np.ascontiguousarray(array).tobytes())
    if point.images is not None:
        sha.update(np.ascontiguousarray(point.images).tobytes())
    sha.update(str(point.ticks).encode())
    return sha.hexdigest()

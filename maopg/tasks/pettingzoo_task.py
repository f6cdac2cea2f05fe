"""An existing PettingZoo environment as a task: its discrete actions become options.

A PettingZoo ``ParallelEnv`` with ``Discrete`` action spaces (masks optional) becomes an option
task: action ``k`` of an agent is the one-tick option ``action_k`` — unless the environment
reports in its infos that the agent is still *busy* (``infos[agent][busy_key]`` true, e.g. a
macro-action simulator in PettingZoo clothes), in which case the agent's option continues and
it does not choose again until it is free: the asynchronous decisions of the option contract.
So every strategy and every learner runs on it unchanged::

    register_pettingzoo("spread", "mpe2.simple_spread_v3:parallel_env",
                        env_kwargs={"N": 3, "max_cycles": 25}, max_ticks=25)
    python -m train --import my_registration --task spread --method async

The team's reward per tick is the mean (or, with ``reward="sum"``, the sum) of the agents'
rewards. An agent that must not act this tick — idle under ``all``, interrupted under ``any`` —
sends ``noop_action``. Observations are the environment's, flattened to float32 (a ``Dict``
observation's ``observation`` entry; its ``action_mask``, or an ``action_mask`` in the infos,
masks the options). The episode ends when every agent is terminated, and is truncated at
``max_ticks`` or when the environment truncates every agent that is not terminated.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from gymnasium import spaces

from maopg.options.base import Execution, Option
from maopg.settings import setting
from maopg.tasks.base import Task, TaskConfig
from maopg.tasks.layout import ObsLayout
from maopg.tasks.registry import RETIRED_KEYWORDS, TaskEntry, register_task


@dataclass(frozen=True)
class PettingZooConfig(TaskConfig):
    """Settings of a wrapped PettingZoo environment (``env.KEY=VALUE`` on the command line)."""

    task_name: str = "pettingzoo"
    """The name it is registered under (what rollouts and videos look it up by)."""
    env: str = ""
    """``"module:factory"`` returning the ``ParallelEnv`` (an env module's ``parallel_env``)."""
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    reward: str = setting("mean", choices=("mean", "sum"))
    """``mean`` or ``sum`` of the agents' rewards: the team's reward per tick."""
    busy_key: str = "busy"
    """Info key that marks an agent still executing its last action (it then continues)."""
    noop_action: int = 0
    """The action of an agent that must not act this tick (idle or interrupted)."""


class Action(Option["PettingZooTask"]):
    """Action ``k`` of the environment: one tick, longer while the environment says busy."""

    def __init__(self, k: int) -> None:
        self.k = k
        self.name = f"action_{k}"

    def available(self, task: PettingZooTask, agent: int) -> bool:
        return task.action_allowed(agent, self.k)

    def step(self, task: PettingZooTask, ex: Execution) -> None:
        task.act(ex.agent, self.k)

    def done(self, task: PettingZooTask, ex: Execution) -> bool:
        return not task.busy(ex.agent)


def _factory(reference: str):
    module, sep, attr = reference.partition(":")
    if not sep:
        raise ValueError(f"env must be 'module:factory', got {reference!r}")
    try:
        return getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as err:
        raise ValueError(f"env {reference!r} cannot be loaded: {err}") from err


class PettingZooTask(Task):
    """The wrapper (see the module docstring)."""

    tick_seconds = 1.0

    def __init__(self, config: PettingZooConfig) -> None:
        if config.images:
            raise ValueError(f"task {config.task_name!r} has no cameras: images=false")
        self.config = config
        self.name = config.task_name
        self.env = _factory(config.env)(**dict(config.env_kwargs))
        self._agents = tuple(self.env.possible_agents)
        self._sizes = []
        for name in self._agents:
            action = self.env.action_space(name)
            if not isinstance(action, spaces.Discrete):
                raise ValueError(
                    f"agent {name!r}: only Discrete actions map to options, got {action}"
                )
            self._sizes.append(int(action.n))
        self._options = [tuple(Action(k) for k in range(n)) for n in self._sizes]
        self.reset(0)
        self._layouts = [ObsLayout.of(observation=len(v)) for v in self._obs]

    # ----------------------------------------------------------------- description
    @property
    def agent_names(self) -> tuple[str, ...]:
        return self._agents

    def robot_of(self, agent: int) -> str:
        return "pettingzoo"

    def options(self, agent: int) -> Sequence[Option[Any]]:
        return self._options[agent]

    def observation_layout(self, agent: int) -> ObsLayout:
        return self._layouts[agent]

    # ----------------------------------------------------------------- dynamics
    def reset(self, seed: int) -> None:
        observations, infos = self.env.reset(seed=seed)
        self._obs = [self._flat(observations[a]) for a in self._agents]
        self._masks = [
            self._mask(observations[a], infos.get(a, {}), i) for i, a in enumerate(self._agents)
        ]
        self._busy = [bool(infos.get(a, {}).get(self.config.busy_key, False)) for a in self._agents]
        self._done = [False] * len(self._agents)
        self._cut = [False] * len(self._agents)
        self._actions = [self.config.noop_action] * len(self._agents)
        self._ticks = 0

    def act(self, agent: int, action: int) -> None:
        self._actions[agent] = action

    def hold(self, agent: int) -> None:
        self._actions[agent] = self.config.noop_action

    def action_allowed(self, agent: int, action: int) -> bool:
        return bool(self._masks[agent][action])

    def busy(self, agent: int) -> bool:
        return self._busy[agent] and not self._done[agent]

    def tick(self) -> float:
        live = set(self.env.agents)
        actions = {a: int(self._actions[i]) for i, a in enumerate(self._agents) if a in live}
        observations, rewards, terminations, truncations, infos = self.env.step(actions)
        for i, a in enumerate(self._agents):
            if a in observations:
                self._obs[i] = self._flat(observations[a])
                self._masks[i] = self._mask(observations[a], infos.get(a, {}), i)
            self._busy[i] = bool(infos.get(a, {}).get(self.config.busy_key, False))
            self._done[i] = self._done[i] or bool(terminations.get(a, False))
            self._cut[i] = self._cut[i] or bool(truncations.get(a, False))
        self._ticks += 1
        values = [float(rewards.get(a, 0.0)) for a in self._agents]
        return float(np.mean(values) if self.config.reward == "mean" else np.sum(values))

    @property
    def ticks(self) -> int:
        return self._ticks

    def terminated(self) -> bool:
        return all(self._done)

    def truncated(self) -> bool:
        """Every agent is done, some by the environment's own time limit."""
        return all(d or c for d, c in zip(self._done, self._cut, strict=True)) and any(self._cut)

    # ----------------------------------------------------------------- observations
    def observe(self, agent: int) -> np.ndarray:
        return self._obs[agent].copy()

    @staticmethod
    def _flat(observation: Any) -> np.ndarray:
        if isinstance(observation, Mapping):
            observation = observation["observation"]
        return np.asarray(observation, dtype=np.float32).ravel()

    def _mask(self, observation: Any, info: Mapping[str, Any], agent: int) -> np.ndarray:
        mask = info.get("action_mask")
        if mask is None and isinstance(observation, Mapping):
            mask = observation.get("action_mask")
        if mask is None:
            return np.ones(self._sizes[agent], dtype=bool)
        return np.asarray(mask, dtype=bool)

    def close(self) -> None:
        self.env.close()


def register_pettingzoo(
    name: str, env: str, *, overwrite: bool = False, **settings: Any
) -> TaskEntry:
    """Register the PettingZoo environment ``env`` (``"module:factory"``) as task ``name``;
    ``settings`` are :class:`PettingZooConfig` defaults of this task (``env_kwargs``,
    ``max_ticks``, ``reward``, ...), and ``train_defaults`` (and the retired grid keywords, to
    be refused there) go to :func:`~maopg.tasks.registry.register_task`."""
    entry_keys = ("train_defaults", *RETIRED_KEYWORDS)
    entry = {k: settings.pop(k) for k in entry_keys if k in settings}
    known = {f.name for f in dataclasses.fields(PettingZooConfig)}
    unknown = sorted(set(settings) - known)
    if unknown:
        raise ValueError(
            f"unknown settings {unknown} for a PettingZoo task; known: {sorted(known)}"
        )
    defaults = {"task_name": name, "env": env, **settings}
    return register_task(
        name,
        PettingZooTask,
        config=PettingZooConfig,
        defaults=defaults,
        overwrite=overwrite,
        **entry,
    )

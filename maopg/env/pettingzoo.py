"""PettingZoo Parallel API view of an :class:`~maopg.env.OptionEnv`.

Every agent is live until the episode ends, so the observation dict always holds every agent
(PettingZoo's rule). Asynchrony is carried by the action masks: an agent that is still executing
its option has a mask with only that option allowed, so any masked sample re-submits it and the
agent simply continues; ``infos[agent]["choosing"]`` says who really chooses (RLlib-style
consumers keep only those). Rewards are the shared reward summed since the previous decision
point; ``infos[agent]["duration"]`` carries the ticks it spans.

An action is an integer (a Python or NumPy integer) per agent. A choosing agent must send one;
a continuing agent may send nothing or its running option (``infos[agent]["running"]``, the one
option its mask allows), anything else is refused: a float, string, NaN or ``None``, an agent
the environment does not have, or another option for an agent still running one each raise a
``ValueError`` naming the agent and the action — nothing is silently replaced.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from pettingzoo import ParallelEnv

from maopg.env.contract import DecisionPoint
from maopg.env.option_env import OptionEnv


class OptionParallelEnv(ParallelEnv):
    """``ParallelEnv`` adapter; observations are dicts with ``observation``, ``action_mask``
    and, when the task renders cameras, ``image``."""

    metadata: ClassVar[dict[str, Any]] = {"name": "maopg_option_env", "render_modes": []}

    def __init__(self, env: OptionEnv) -> None:
        self.env = env
        self.possible_agents = list(env.spec.agent_names)
        self.agents: list[str] = []
        self._point: DecisionPoint | None = None
        # PettingZoo requires the very same space object on every call.
        self._observation_spaces: dict[str, gym.spaces.Dict] = {}
        self._action_spaces: dict[str, gym.spaces.Discrete] = {}
        for agent in env.spec.agents:
            spaces: dict[str, gym.Space] = {
                "observation": gym.spaces.Box(-np.inf, np.inf, (agent.vector_size,), np.float32),
                "action_mask": gym.spaces.MultiBinary(agent.num_options),
            }
            if env.spec.image_shape is not None:
                spaces["image"] = gym.spaces.Box(0, 255, env.spec.image_shape, np.uint8)
            self._observation_spaces[agent.name] = gym.spaces.Dict(spaces)
            self._action_spaces[agent.name] = gym.spaces.Discrete(agent.num_options)

    def observation_space(self, agent: str) -> gym.spaces.Dict:
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> gym.spaces.Discrete:
        return self._action_spaces[agent]

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, Any]]]:
        self._point = self.env.reset(seed=seed)
        self.agents = list(self.possible_agents)
        return self._observations(), self._infos()

    def step(self, actions: dict[str, int]) -> tuple[dict, dict, dict, dict, dict]:
        point = self._point
        if point is None or not self.agents:
            raise ValueError("step() called before reset() or after the episode ended")
        self._point = point = self.env.step(self._joint(point, actions))
        observations, infos = self._observations(), self._infos()
        rewards = dict.fromkeys(self.agents, float(point.reward))
        terminated = dict.fromkeys(self.agents, point.terminated)
        truncated = dict.fromkeys(self.agents, point.truncated)
        if point.done:
            self.agents = []
        return observations, rewards, terminated, truncated, infos

    def close(self) -> None:
        self.env.close()

    def _joint(self, point: DecisionPoint, actions: dict[str, Any]) -> np.ndarray:
        """The joint option of ``actions`` (the rules are in the module docstring)."""
        unknown = [a for a in actions if a not in self.possible_agents]
        if unknown:
            raise ValueError(
                f"action for unknown agent(s) {unknown}; the agents are {self.possible_agents}"
            )
        missing = [a for i, a in enumerate(self.agents) if point.choosing[i] and a not in actions]
        if missing:
            raise ValueError(f"agents {missing} are choosing (in U_t) and need an action")
        joint = point.running.astype(np.int64)
        for i, agent in enumerate(self.possible_agents):
            if agent not in actions:
                continue
            action = actions[agent]
            if not isinstance(action, int | np.integer) or isinstance(action, bool | np.bool_):
                raise ValueError(f"agent {agent!r}: action {action!r} is not an integer option")
            if not point.choosing[i] and action != point.running[i]:
                raise ValueError(
                    f"agent {agent!r}: action {action!r}, but it is still running option "
                    f"{point.running[i]}; send that (or no action) until it chooses"
                )
            joint[i] = int(action)
        return joint

    def _observations(self) -> dict[str, dict[str, np.ndarray]]:
        point = self._point
        out = {}
        for i, agent in enumerate(self.possible_agents):
            mask = point.available[i].astype(np.int8)
            if not point.choosing[i]:
                mask = np.zeros_like(mask)
                mask[point.running[i]] = 1
            obs = {"observation": point.vectors[i].copy(), "action_mask": mask}
            if point.images is not None:
                obs["image"] = point.images[i].copy()
            out[agent] = obs
        return out

    def _infos(self) -> dict[str, dict[str, Any]]:
        point = self._point
        return {
            agent: {
                "choosing": bool(point.choosing[i]),
                "running": int(point.running[i]),
                "duration": point.duration,
                "ticks": point.ticks,
            }
            for i, agent in enumerate(self.possible_agents)
        }

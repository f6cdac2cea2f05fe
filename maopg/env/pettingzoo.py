"""PettingZoo Parallel API view of an :class:`~maopg.env.OptionEnv`.

Every agent is live until the episode ends, so the observation dict always holds every agent
(PettingZoo's rule). Asynchrony is carried by the action masks: an agent that is still executing
its option has a mask with only that option allowed, so any masked sample re-submits it and the
agent simply continues; ``infos[agent]["choosing"]`` says who really chooses (RLlib-style
consumers keep only those). Rewards are the shared reward summed since the previous decision
point; ``infos[agent]["duration"]`` carries the ticks it spans and
``infos[agent]["discounted_reward"]`` its γ-discounted sum (``Σ_j γ^j r_j``), which is what an
outside learner needs for the SMDP target ``discounted_reward + γ^duration · V(next)``.

An action is an integer (a Python or NumPy integer) per agent. A choosing agent must send one;
a continuing agent may send nothing or its running option (``infos[agent]["running"]``, the one
option its mask allows), anything else is refused: a float, string, NaN or ``None``, an agent
the environment does not have, or another option for an agent still running one each raise a
``ValueError`` naming the agent and the action — nothing is silently replaced.

:meth:`OptionParallelEnv.state` is the joint observation vector a centralized critic sees (the
agents' vectors concatenated in agent order); camera images are not part of it — they stay in
each agent's observation under ``"image"``. :func:`decision_point` turns an observation dict and
its infos back into the :class:`DecisionPoint` they were made from, so anything that acts on
decision points (a trained policy, a reference policy) acts on the PettingZoo view too.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from pettingzoo import ParallelEnv

from maopg.env import make_env
from maopg.env.contract import DecisionPoint, ImageChannels
from maopg.env.option_env import OptionEnv
from maopg.env.panel import panel_items
from maopg.env.timeline import TimelineRecorder
from maopg.env.video import FrameComposer, Overlay

RENDER_MODES = ("rgb_array",)
INFO_KEYS = ("choosing", "running", "duration", "ticks", "discounted_reward")
"""What ``infos[agent]`` holds at every reset and step (all scalars, so that wrappers such as
TorchRL's ``PettingZooWrapper`` can give them a spec)."""


def image_space(shape: tuple[int, int, int], channels: ImageChannels) -> gym.spaces.Box:
    """An agent's camera image as a gym space: each plane bounded as its channel is (colour
    0-255, depth ``near``-``far`` metres, class ids 0 to the last class), in the channels'
    dtype (uint8, float32 with depth)."""
    low, high = (np.broadcast_to(np.asarray(b, channels.dtype), shape) for b in channels.bounds())
    return gym.spaces.Box(low, high, shape, np.dtype(channels.dtype))


class OptionParallelEnv(ParallelEnv):
    """``ParallelEnv`` adapter; observations are dicts with ``observation``, ``action_mask``
    and, when the task renders cameras, ``image``.

    ``image`` is ``[H, W, planes]`` of the task's camera channels (colour alone: uint8
    ``[H, W, 3]``; :func:`image_space`).

    ``render_mode="rgb_array"`` makes :meth:`render` return the frame a rollout video shows at
    this decision point (:class:`~maopg.env.video.FrameComposer`: the overview camera, the state
    panel and every robot's camera); its renderers are made at the first call, so a view that
    never renders opens no GL context.
    """

    metadata: ClassVar[dict[str, Any]] = {
        "name": "maopg_option_env",
        "render_modes": list(RENDER_MODES),
        "is_parallelizable": True,
    }

    def __init__(self, env: OptionEnv, render_mode: str | None = None) -> None:
        if render_mode is not None and render_mode not in RENDER_MODES:
            raise ValueError(
                f"render_mode must be None or one of {RENDER_MODES}, got {render_mode!r}"
            )
        self.env = env
        self.render_mode = render_mode
        self.possible_agents = list(env.spec.agent_names)
        self.agents: list[str] = []
        self._point: DecisionPoint | None = None
        self._return = 0.0
        self._tick_reward: float | None = None
        self._composer: FrameComposer | None = None
        self._timeline = TimelineRecorder(env.num_agents)
        """The options so far, for the frame's timeline strip."""
        if render_mode is not None:
            env.add_tick_listener(self._on_tick)
        # PettingZoo requires the very same space object on every call.
        self._observation_spaces: dict[str, gym.spaces.Dict] = {}
        self._action_spaces: dict[str, gym.spaces.Discrete] = {}
        for agent in env.spec.agents:
            spaces: dict[str, gym.Space] = {
                "observation": gym.spaces.Box(-np.inf, np.inf, (agent.vector_size,), np.float32),
                "action_mask": gym.spaces.MultiBinary(agent.num_options),
            }
            if env.spec.image_shape is not None:
                spaces["image"] = image_space(env.spec.image_shape, env.spec.image_channels)
            self._observation_spaces[agent.name] = gym.spaces.Dict(spaces)
            self._action_spaces[agent.name] = gym.spaces.Discrete(agent.num_options)
        state_size = sum(agent.vector_size for agent in env.spec.agents)
        self.state_space = gym.spaces.Box(-np.inf, np.inf, (state_size,), np.float32)

    def observation_space(self, agent: str) -> gym.spaces.Dict:
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> gym.spaces.Discrete:
        return self._action_spaces[agent]

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, Any]]]:
        self._point = self.env.reset(seed=seed)
        self.agents = list(self.possible_agents)
        self._return, self._tick_reward = 0.0, None
        self._timeline = TimelineRecorder(self.env.num_agents)
        return self._observations(), self._infos()

    def step(self, actions: dict[str, int]) -> tuple[dict, dict, dict, dict, dict]:
        point = self._point
        if point is None or not self.agents:
            raise ValueError("step() called before reset() or after the episode ended")
        joint = self._joint(point, actions)
        self._timeline.decide(point)
        self._point = point = self.env.step(joint)
        self._return += point.reward
        observations, infos = self._observations(), self._infos()
        rewards = dict.fromkeys(self.agents, float(point.reward))
        terminated = dict.fromkeys(self.agents, point.terminated)
        truncated = dict.fromkeys(self.agents, point.truncated)
        if point.done:
            self.agents = []
        return observations, rewards, terminated, truncated, infos

    def state(self) -> np.ndarray:
        """The joint observation: every agent's vector, concatenated in agent order (float32
        ``[Σ vector_size]``, :attr:`state_space`), as the centralized critic sees it."""
        point = self._require_point("state")
        return np.concatenate(point.vectors).astype(np.float32)

    def render(self) -> np.ndarray | None:
        """The current frame, uint8 ``[H, W, 3]`` (see the class docstring); the agents that
        choose now are highlighted. ``None``, with a warning, without ``render_mode``."""
        if self.render_mode is None:
            gym.logger.warn("render() needs OptionParallelEnv(..., render_mode='rgb_array')")
            return None
        point = self._require_point("render")
        if self._composer is None:
            env = self.env
            title = f"{env.task.name} | {env.strategy.value}"
            self._composer = FrameComposer.of_env(env, title)
        options = self.env.running_option_names()
        overlay = Overlay(
            tick=point.ticks,
            ret=self._return,
            reward=self._tick_reward,
            options=options,
            started=point.choosing.tolist(),
            state=panel_items(self.env.task.name, self.env.task.describe()),
            progress=self._timeline.progress(options, point.ticks),
            timeline=self._timeline.rows(),
        )
        return self._composer.compose(overlay)

    def close(self) -> None:
        if self._composer is not None:
            self._composer.close()
            self._composer = None
        self.env.close()

    def _on_tick(self, env: OptionEnv, reward: float) -> None:
        self._tick_reward = reward  # the panel's "last tick" reward
        self._timeline.on_tick(env, reward)

    def _require_point(self, method: str) -> DecisionPoint:
        if self._point is None:
            raise ValueError(f"{method}() called before reset()")
        return self._point

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
                "discounted_reward": float(point.discounted_reward),
            }
            for i, agent in enumerate(self.possible_agents)
        }


def parallel_env(
    task: str = "tool_delivery",
    strategy: str = "continue",
    *,
    render_mode: str | None = None,
    **kwargs: Any,
) -> OptionParallelEnv:
    """A task's PettingZoo view, as a PettingZoo environment module's ``parallel_env`` makes
    one; ``kwargs`` are :func:`maopg.env.make_env`'s (``seed``, ``images``, ``image_size``,
    ``gamma``, ``overrides``)."""
    return OptionParallelEnv(make_env(task, strategy, **kwargs), render_mode=render_mode)


def decision_point(
    agents: Sequence[str],
    observations: Mapping[str, Mapping[str, np.ndarray]],
    infos: Mapping[str, Mapping[str, Any]],
) -> DecisionPoint:
    """The :class:`DecisionPoint` behind a view's ``observations`` and ``infos`` (of
    :meth:`OptionParallelEnv.reset` or ``step``), its arrays in ``agents`` order.

    A continuing agent's availability is its mask (only its running option), which is all a
    policy reads of it: its option is fixed. Rewards are not part of an observation and are
    left at 0; ``duration``, ``ticks`` and the discounted reward come from the infos, so a
    recurrent policy sees the episode start (``ticks == 0``) where it restarts its memory.
    """
    missing = [a for a in agents if a not in observations or a not in infos]
    if missing:
        raise ValueError(f"observations and infos lack agent(s) {missing}; need {list(agents)}")
    for agent in agents:
        absent = [key for key in INFO_KEYS if key not in infos[agent]]
        if absent:
            raise ValueError(
                f"infos[{agent!r}] lacks {absent}: pass the infos of OptionParallelEnv's "
                "reset() or step() that came with these observations"
            )
    first = infos[agents[0]]
    images = None
    if "image" in observations[agents[0]]:
        images = np.stack([observations[a]["image"] for a in agents])
    return DecisionPoint(
        vectors=tuple(np.asarray(observations[a]["observation"], np.float32) for a in agents),
        images=images,
        choosing=np.array([infos[a]["choosing"] for a in agents], dtype=bool),
        running=np.array([infos[a]["running"] for a in agents], dtype=np.int64),
        available=tuple(np.asarray(observations[a]["action_mask"], bool) for a in agents),
        discounted_reward=float(first["discounted_reward"]),
        duration=int(first["duration"]),
        ticks=int(first["ticks"]),
    )

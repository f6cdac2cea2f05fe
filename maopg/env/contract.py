"""The option-level contract: the one interface between tasks and learners.

Every learner (MAPPO in its variants, Mac-DQN, evaluation) consumes exactly what is defined
here, and every task — ours or a user's — produces it through :class:`maopg.env.OptionEnv`.

Time scales
-----------
A *tick* (low-level step ``k``) is one control period of the task: a fixed amount of simulated
time, many physics substeps. One tick is one *sample* for sample counting, as in the paper.
A *decision point* (option step ``t``) is a tick boundary at which at least one agent must
choose a new option ("soft-sync"). The set of choosing agents is ``U_t`` (``choosing``); the
others keep executing ``running[i]``.

Termination strategies (:class:`Strategy`)
------------------------------------------
``continue``  only agents whose option ended choose; the others continue (the paper's method).
``any``       when any option ends, every running option is interrupted and all agents choose.
``all``       agents whose option ended idle (hold position) until all have ended; all choose.
``primitive`` every agent chooses a one-tick primitive action at every tick (end2end baseline).

Reward
------
``reward`` is the **sum** of the per-tick shared rewards over the ``duration`` ticks since the
previous decision point, ``discounted_reward`` is ``sum_j gamma**j * r_j`` over the same ticks,
so a learner bootstraps with ``gamma**duration``. (The original code returned the last tick's
reward only; that is a bug we do not reproduce.)

Physics warnings
----------------
MuJoCo answers a numerical instability (too stiff gains for the timestep, say) by resetting the
state and carrying on. A tick in which that happened (the scene raises
:class:`maopg.sim.scene.PhysicsInstability`) ends the episode at once: the point is
``truncated`` (its ``duration`` counts the lost tick, which earns no reward; ``ticks`` counts
the ticks the task completed), every agent is marked choosing, ``info["physics_warning"]`` names
the warning and the robot, and ``info["episode"]["solved"]`` is False, so a run of broken
physics never reports a solved task. Learners treat it like any truncation.

Joint options
-------------
``OptionEnv.step(joint_option)`` takes one integer per agent. Entries of agents in ``U_t`` must be
available options of that agent; entries of agents not in ``U_t`` must equal their running
option (what a conditional policy's joint sample contains) or be ``-1``.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from maopg.options.base import Strategy, option_index
from maopg.sim.channels import RGB, ImageChannels

if TYPE_CHECKING:  # at run time the contract stays free of the task layer's imports
    from maopg.tasks.layout import ObsLayout


__all__ = ["AgentSpec", "DecisionPoint", "EnvSpec", "ImageChannels", "Strategy"]


@dataclass(frozen=True)
class AgentSpec:
    """Static description of one agent, fixed for the lifetime of an environment."""

    name: str
    robot: str
    option_names: tuple[str, ...]
    """Names of the agent's options (or primitive actions in ``primitive`` mode), index = id."""
    vector_size: int
    """Length of the agent's observation vector."""
    layout: ObsLayout | None = None
    """Named fields of the observation vector (``None``: unnamed)."""

    def __post_init__(self) -> None:
        if self.layout is not None and self.layout.size != self.vector_size:
            raise ValueError(
                f"agent {self.name!r}: layout {self.layout.names} has {self.layout.size} values, "
                f"vector_size is {self.vector_size}"
            )

    @property
    def num_options(self) -> int:
        return len(self.option_names)

    def option_index(self, name: str) -> int:
        """Id of the option called ``name`` (a ``ValueError`` lists the agent's options)."""
        return option_index(self.option_names, name, self.name)


@dataclass(frozen=True)
class EnvSpec:
    """Static description of an option environment: what a learner sizes its networks from."""

    task: str
    strategy: Strategy
    agents: tuple[AgentSpec, ...]
    image_shape: tuple[int, int, int] | None
    """``(H, W, planes)`` of every agent's camera image (``planes``: 3 for colour alone, see
    :attr:`image_channels`), or ``None`` when images are off."""
    tick_seconds: float
    max_ticks: int
    gamma: float
    image_channels: ImageChannels = RGB
    """What the planes of an image hold, their value ranges and dtype
    (:class:`~maopg.sim.channels.ImageChannels`): an encoder normalises each channel by it."""
    state_size: int | None = None
    """Length of the task's global state (:attr:`DecisionPoint.state`), ``None`` without one."""

    def __post_init__(self) -> None:
        if self.image_shape is not None and self.image_shape[2] != self.image_channels.planes:
            raise ValueError(
                f"image_shape {self.image_shape} does not hold the {self.image_channels.planes} "
                f"planes of channels {'+'.join(self.image_channels.names)}"
            )

    @property
    def num_agents(self) -> int:
        return len(self.agents)

    @property
    def option_counts(self) -> tuple[int, ...]:
        return tuple(a.num_options for a in self.agents)

    @property
    def agent_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.agents)


@dataclass
class DecisionPoint:
    """Everything an environment reports at a decision point (and at reset).

    Arrays are indexed by agent in ``EnvSpec.agents`` order. An option environment owns its
    buffers: whoever keeps a point it returned across its steps copies it (:meth:`copy`), as a
    vector environment does for the learners.
    """

    vectors: tuple[np.ndarray, ...]
    """Per-agent float32 observation vectors (each refreshed when that agent's option ends)."""
    images: np.ndarray | None
    """``[N, H, W, planes]`` camera images rendered at this decision point (uint8 ``[N, H,
    W, 3]`` for colour alone; dtype and planes: :attr:`EnvSpec.image_channels`), or
    ``None``."""
    choosing: np.ndarray
    """``bool [N]``: the mask ``U_t`` of agents that must choose now."""
    running: np.ndarray
    """``int64 [N]``: option executing for each agent; for choosing agents the option that just
    ended (``-1`` at reset). ``running[~choosing]`` is ``o^{Ū}``, the condition ``c``."""
    available: tuple[np.ndarray, ...]
    """Per-agent ``bool [K_i]`` availability masks (meaningful for choosing agents)."""
    reward: float = 0.0
    """Sum of per-tick shared rewards since the previous decision point (0 at reset)."""
    discounted_reward: float = 0.0
    """``sum_j gamma**j r_j`` over the same ticks."""
    duration: int = 0
    """Number of ticks ``k`` since the previous decision point (0 at reset)."""
    terminated: bool = False
    """The task reached a terminal state (bootstrap with 0)."""
    truncated: bool = False
    """The episode hit the tick limit, or its physics went unstable (``info["physics_warning"]``);
    bootstrap from the value of this point."""
    ticks: int = 0
    """Ticks elapsed since reset (the episode's low-level time)."""
    info: dict[str, Any] = field(default_factory=dict)
    state: np.ndarray | None = None
    """The task's global state at this point (float32 ``[EnvSpec.state_size]``) where the task
    has one, for the critics that take it; no policy reads it."""

    @property
    def done(self) -> bool:
        return self.terminated or self.truncated

    def copy(self) -> DecisionPoint:
        """A copy that owns its arrays and ``info``: what a vector environment hands out, so no
        later step of the environment that made this point changes it. Field by field: cheaper
        than ``copy.deepcopy``, whose generic walk costs a noticeable part of a grid step."""
        return replace(
            self,
            vectors=tuple(v.copy() for v in self.vectors),
            images=None if self.images is None else self.images.copy(),
            choosing=self.choosing.copy(),
            running=self.running.copy(),
            available=tuple(a.copy() for a in self.available),
            info=copy.deepcopy(self.info),
            state=None if self.state is None else self.state.copy(),
        )

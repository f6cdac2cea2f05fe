"""What every learner implements, so that one training loop runs any method.

A learner owns its networks, its optimisers and its *collection loop*: each :meth:`iteration`
steps the environments (a :class:`~maopg.env.vector.SeededVectorEnv`, which knows nothing of the
algorithm) for at least ``batch_ticks`` low-level ticks with its own acting rule and learns from
what it saw. The trainer only counts samples, logs the returned row and checkpoints
:meth:`state_dict`. A new learner subclasses :class:`Learner`; a method pairs it with a
termination strategy and a policy builder (``maopg.experiment.run.methods``).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import torch
from torch import Tensor, nn

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.env.vector import SeededVectorEnv
from maopg.learner.errors import NonFiniteError
from maopg.policy import set_precision

CPU = torch.device("cpu")

SHARED_COLUMNS = (
    "iteration",
    "samples",
    "option_steps",
    "episodes",
    "episode_return",
    "episode_length",
    "success_rate",
    "option_step_reward",
)
"""What every learner reports first (``iteration`` and ``samples`` are the trainer's).
``episode_return`` (mean return of the episodes that ended in the iteration, NaN if none) is the
primary metric; ``option_step_reward`` (mean summed reward per option step of the batch) is the
paper's metric — the two are different quantities and must not be compared."""

Actor = Callable[[DecisionPoint], np.ndarray]
"""A trained policy in the ``DecisionPoint -> joint option`` protocol of evaluation and video."""


def require_finite(value: Tensor, what: str) -> None:
    """Raise :class:`NonFiniteError` naming ``what`` unless every entry of ``value`` is finite.
    Reads only, so it changes no number of a healthy run."""
    if not bool(torch.isfinite(value).all()):
        shown = f"{value.item()}" if value.numel() == 1 else "non-finite"
        raise NonFiniteError(f"{what} became {shown}")


def require_finite_parameters(module: nn.Module, what: str) -> None:
    """:func:`require_finite` over every parameter of ``module`` (after an optimiser step)."""
    for name, parameter in module.named_parameters():
        require_finite(parameter.detach(), f"{what}'s parameter {name}")


@dataclass(frozen=True)
class LearnerSetup:
    """The run-level settings a learner is built from (its own hyper-parameters are ``config``,
    the method's config section)."""

    spec: EnvSpec
    config: Any
    """The learner's config section (an instance of :attr:`Learner.Config`)."""
    num_envs: int
    batch_ticks: int
    gamma: float
    hidden: int
    """Width of the encoders' MLP layers (networks the learner builds itself, e.g. a critic)."""
    layers: int
    sample_gen: torch.Generator
    """Draws every acting decision (checkpointed by the trainer)."""
    update_gen: torch.Generator
    """Draws minibatches and replay samples (checkpointed by the trainer)."""
    device: torch.device = CPU
    """Where the learner's networks, optimiser state and updates live (the run's resolved
    ``device``). The generators stay CPU generators whatever it is: every random draw is made
    on the CPU from them and its result moved to the device, so a ``cpu`` run draws exactly as
    it always has and a ``cuda`` run's draws are as reproducible as its probabilities
    (:func:`maopg.policy.conditional.draw_multinomial`)."""
    precision: str = "fp32"
    """What the image encoders of the learner's networks compute in (the run's ``precision``;
    :func:`maopg.policy.encoders.set_precision`): the learner sets it on every network it
    builds itself."""


class Learner(ABC):
    """One method's learning algorithm (see the module docstring)."""

    Config: ClassVar[type]
    """The dataclass of its hyper-parameters: the config section ``<section>.<field>=value``.
    It has a ``validate()`` that raises ``ValueError`` naming a bad field, and may have a
    ``check_task(task_config)`` that does the same for a relation with the run's task settings
    (:meth:`maopg.learner.sections.MacDQNConfig.check_task`), called before a run builds
    anything."""
    section: ClassVar[str]
    """Name of its config section (``ppo``, ``dqn``)."""
    columns: ClassVar[tuple[str, ...]]
    """Its own ``metrics.csv`` columns, logged after :data:`SHARED_COLUMNS`."""
    policy_key: ClassVar[str]
    """The ``final.pt`` entry holding the acting network's weights."""
    sampled_name: ClassVar[str] = "sampled"
    """How its non-greedy :meth:`actor` acts, in a video's title (Mac-DQN: ``ε-greedy``)."""

    def __init__(self, policy: nn.Module, setup: LearnerSetup) -> None:
        # Built on the CPU from torch's global RNG (the same initial weights on every device),
        # then moved: a subclass builds its optimisers after this, on the moved parameters.
        self.policy = policy.to(setup.device)
        set_precision(self.policy, setup.precision)
        self.setup = setup
        self.device = setup.device
        self.config = setup.config

    @abstractmethod
    def iteration(self, envs: SeededVectorEnv, samples: int) -> tuple[dict[str, Any], int]:
        """Collect at least ``batch_ticks`` ticks (``samples`` so far) and learn; return the
        metrics row (the shared columns but iteration and samples, then :attr:`columns`) and
        the ticks taken."""

    def final_state(self) -> dict[str, Any]:
        """What ``final.pt`` keeps to rebuild the acting policy."""
        return {self.policy_key: self.policy.state_dict()}

    @abstractmethod
    def state_dict(self) -> dict[str, Any]:
        """Networks, optimisers and learner state for ``checkpoint.pt`` (top-level keys)."""

    @abstractmethod
    def load_state_dict(self, state: dict[str, Any]) -> None: ...

    @staticmethod
    @abstractmethod
    def actor(policy: nn.Module, config: Any, *, greedy: bool, seed: int) -> Actor:
        """The trained ``policy`` acting on decision points: its mode (``greedy``) or sampled as
        in training, seeded with ``seed``."""


def mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else math.nan


def episode_metrics(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """The shared columns about the episodes that ended in an iteration (NaN if none did)."""
    return {
        "episodes": len(episodes),
        "episode_return": mean([e["return"] for e in episodes]),
        "episode_length": mean([e["ticks"] for e in episodes]),
        "success_rate": mean([e["solved"] for e in episodes]),
    }

"""Trained policies for evaluation: load a checkpoint, rebuild its environment, act on points.

A checkpoint (``final.pt`` or ``checkpoint.pt`` from ``python -m train``) stores the resolved
training config and the policy's weights — a MAPPO policy, or Mac-DQN's Q-network — and the
config says which task, termination strategy, observation kind and network sizes to rebuild, so
nothing needs to be given twice.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from maopg.env import DecisionPoint, OptionEnv
from maopg.learner import CheckpointError, JointQNetwork, load_checkpoint
from maopg.learner.macdqn import epsilon_greedy
from maopg.policy import ObsBatch, OptionPolicy, build_policy, stack_conditions
from train.config import JOINT_Q, TrainConfig
from train.run_log import CHECKPOINT, FINAL

CHECKPOINT_NAMES = (FINAL, CHECKPOINT)
"""Looked for, in this order, when a run directory is given instead of a file."""


class NetworkPolicy:
    """Adapts an :class:`OptionPolicy` to the ``DecisionPoint -> joint option`` protocol of
    :func:`maopg.rollout.run_episode` and :func:`maopg.video.record_episode`.

    ``greedy`` takes the mode of the conditional (deterministic); otherwise options are sampled
    from a generator seeded with ``seed``, so a stochastic evaluation is reproducible too.
    """

    def __init__(self, policy: OptionPolicy, *, greedy: bool = True, seed: int = 0) -> None:
        self.policy = policy.eval()
        self.greedy = greedy
        self.generator = torch.Generator().manual_seed(seed)

    @torch.no_grad()
    def __call__(self, point: DecisionPoint) -> np.ndarray:
        obs = ObsBatch.from_decision_points([point])
        dist = self.policy.distribution(obs, *stack_conditions([point]))
        joint = dist.mode() if self.greedy else dist.sample(self.generator)
        return joint[0].numpy()


class QNetworkPolicy:
    """Mac-DQN's policy in the same protocol: the conditional argmax of the joint Q-network
    (continuing agents keep their options), ε-greedy within that slice when ``epsilon`` > 0.

    A recurrent Q-network's history restarts at every episode's reset point (``ticks == 0``).
    """

    def __init__(self, q: JointQNetwork, *, epsilon: float = 0.0, seed: int = 0) -> None:
        self.q = q.eval()
        self.epsilon = epsilon
        self.generator = torch.Generator().manual_seed(seed)
        self.state = q.initial_state(1)

    @torch.no_grad()
    def __call__(self, point: DecisionPoint) -> np.ndarray:
        if point.ticks == 0:
            self.state = self.q.initial_state(1)
        values, self.state = self.q.step(ObsBatch.from_decision_points([point]), self.state)
        joint = epsilon_greedy(
            values,
            *stack_conditions([point]),
            self.q.option_counts,
            self.epsilon,
            self.generator,
        )
        return joint[0].numpy()


@dataclass
class Trained:
    """A checkpoint's config and network (an option policy, or Mac-DQN's Q-network)."""

    path: Path
    config: TrainConfig
    policy: OptionPolicy | JointQNetwork
    samples: int

    def make_env(self, seed: int = 0) -> OptionEnv:
        """The environment the policy was trained on (task, strategy, observations)."""
        return self.config.env().make(seed)

    def actor(self, *, greedy: bool = True, seed: int = 0) -> Callable[[DecisionPoint], np.ndarray]:
        """The trained policy as ``DecisionPoint -> joint option``: the mode (greedy) or a
        sample seeded with ``seed`` — for Mac-DQN, ε-greedy at its final exploration rate."""
        if isinstance(self.policy, JointQNetwork):
            epsilon = 0.0 if greedy else self.config.dqn.eps_end
            return QNetworkPolicy(self.policy, epsilon=epsilon, seed=seed)
        return NetworkPolicy(self.policy, greedy=greedy, seed=seed)


def resolve_checkpoint(path: str | Path) -> Path:
    """``path`` itself if it is a file, else the first of :data:`CHECKPOINT_NAMES` in it."""
    path = Path(path)
    if path.is_file():
        return path
    for name in CHECKPOINT_NAMES:
        if (path / name).is_file():
            return path / name
    raise FileNotFoundError(f"{path} is neither a checkpoint file nor a run directory with one")


def load_trained(path: str | Path) -> Trained:
    """Rebuild the policy of a checkpoint (file or run directory) with its weights."""
    file = resolve_checkpoint(path)
    state = load_checkpoint(file, required=("config",))
    config = TrainConfig.from_dict(state["config"]).resolved()
    env = config.env().make(0)
    try:
        spec = env.spec
    finally:
        env.close()
    size = {"hidden": config.hidden, "layers": config.layers}
    policy: OptionPolicy | JointQNetwork
    if config.policy_kind == JOINT_Q:
        key = "q"
        policy = JointQNetwork(
            spec, recurrent=config.dqn.recurrent, use_images=bool(config.images), **size
        )
    else:
        key = "policy"
        policy = build_policy(config.policy_kind, spec, **size)  # type: ignore[arg-type]
    if key not in state:
        raise CheckpointError(f"checkpoint {file} lacks the entries [{key!r}]")
    policy.load_state_dict(state[key])
    return Trained(file, config, policy, int(state.get("samples", 0)))

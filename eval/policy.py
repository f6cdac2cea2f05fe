"""Trained policies for evaluation: load a checkpoint, rebuild its environment, act on points.

A checkpoint (``final.pt`` or ``checkpoint.pt`` from ``python -m train``) stores the resolved
training config and the policy's weights; the config says which task, termination strategy,
observation kind and network sizes to rebuild, so nothing needs to be given twice.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from maopg.env import DecisionPoint, OptionEnv
from maopg.learner import load_checkpoint
from maopg.policy import ObsBatch, OptionPolicy, build_policy, stack_conditions
from train.config import TrainConfig

CHECKPOINT_NAMES = ("final.pt", "checkpoint.pt")
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


@dataclass
class Trained:
    """A checkpoint's config and policy network."""

    path: Path
    config: TrainConfig
    policy: OptionPolicy
    samples: int

    def make_env(self, seed: int = 0) -> OptionEnv:
        """The environment the policy was trained on (task, strategy, observations)."""
        return self.config.env().make(seed)


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
    state = load_checkpoint(file, required=("config", "policy"))
    config = TrainConfig.from_dict(state["config"]).resolved()
    env = config.env().make(0)
    try:
        spec = env.spec
    finally:
        env.close()
    policy = build_policy(
        config.policy_kind,  # type: ignore[arg-type]
        spec,
        hidden=config.hidden,
        layers=config.layers,
    )
    policy.load_state_dict(state["policy"])
    return Trained(file, config, policy, int(state.get("samples", 0)))

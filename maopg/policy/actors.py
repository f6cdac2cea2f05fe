"""Trained networks acting on single decision points: the ``DecisionPoint -> joint option``
protocol of evaluation, videos and the reference policies.

Each keeps its own seeded generator, so a stochastic evaluation is as reproducible as a greedy
one, and neither imports anything of training.
"""

from __future__ import annotations

import numpy as np
import torch

from maopg.env.contract import DecisionPoint
from maopg.policy.batch import ObsBatch, stack_conditions
from maopg.policy.conditional import epsilon_greedy
from maopg.policy.networks import JointQNetwork, OptionPolicy


class DistributionActor:
    """An :class:`OptionPolicy`'s conditional: its mode (``greedy``) or a seeded sample."""

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


class QActor:
    """A joint Q-network's conditional argmax (continuing agents keep their options), ε-greedy
    within that slice when ``epsilon`` > 0.

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

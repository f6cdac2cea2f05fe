"""Trained networks acting on single decision points: the ``DecisionPoint -> joint option``
protocol of evaluation, videos and the reference policies.

Each keeps its own seeded generator, so a stochastic evaluation is as reproducible as a greedy
one, and neither imports anything of training. They act on whatever device the network is on
(a point's tensors go there; the generator stays a CPU generator, see
:func:`~maopg.policy.conditional.draw_multinomial`) and hand back numpy.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from maopg.env.contract import DecisionPoint
from maopg.policy.batch import ObsBatch, stack_conditions
from maopg.policy.conditional import epsilon_greedy
from maopg.policy.networks import JointQNetwork, OptionPolicy


def _device(network: torch.nn.Module) -> torch.device:
    return next(network.parameters()).device


def _point_tensors(point: DecisionPoint, device: torch.device) -> tuple:
    """``(obs, choosing, running, available)`` of ``point``, as a batch of one on ``device``."""
    return (
        ObsBatch.from_decision_points([point]).to(device),
        *(t.to(device) for t in stack_conditions([point])),
    )


def episode_starts(points: Sequence[DecisionPoint]) -> torch.Tensor:
    """``bool [B]``: which points open an episode (``ticks == 0``), where memory restarts."""
    return torch.tensor([p.ticks == 0 for p in points], dtype=torch.bool)


class DistributionActor:
    """An :class:`OptionPolicy`'s conditional: its mode (``greedy``) or a seeded sample.

    A recurrent policy's state is carried from one call to the next, as in training (each point
    advances it, a partially centralized policy's per-agent slots only where that agent
    chooses), and restarts at every episode's reset point (``ticks == 0``); so one actor plays
    one episode at a time, its points in order.
    """

    def __init__(self, policy: OptionPolicy, *, greedy: bool = True, seed: int = 0) -> None:
        self.policy = policy.eval()
        self.greedy = greedy
        self.generator = torch.Generator().manual_seed(seed)
        self.state = policy.initial_state(1)

    @torch.no_grad()
    def __call__(self, point: DecisionPoint) -> np.ndarray:
        device = _device(self.policy)
        starts = episode_starts([point]).to(device)
        dist, self.state = self.policy.step(*_point_tensors(point, device), self.state, starts)
        joint = dist.mode() if self.greedy else dist.sample(self.generator)
        return joint[0].cpu().numpy()


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
        if episode_starts([point])[0]:
            self.state = self.q.initial_state(1)
        obs, *conditions = _point_tensors(point, _device(self.q))
        values, self.state = self.q.step(obs, self.state)
        joint = epsilon_greedy(
            values, *conditions, self.q.option_counts, self.epsilon, self.generator
        )
        return joint[0].cpu().numpy()

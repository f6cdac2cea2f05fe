"""Option policies, the centralized critic and the joint Q-network (docs/DESIGN.md §4-§6).

:class:`OptionPolicy` is the seam a learner depends on: given a batch of joint observations and
the condition of each decision point (who chooses, what the others run, what is available) it
returns a distribution over joint options. The product categorical behind
:class:`CentralizedPolicy` is exact but grows as ``ΠK_i``; a factored or autoregressive
conditional policy for many agents would implement the same interface.

:class:`JointQNetwork` is Mac-DQN's acting network: a value for every joint option, acted on by
the conditional argmax of :mod:`maopg.policy.conditional`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import torch
from torch import Tensor, nn

from maopg.env.contract import EnvSpec
from maopg.policy.batch import ObsBatch
from maopg.policy.conditional import (
    ConditionalJoint,
    FactoredConditional,
    JointOptionDistribution,
    partial_conditional_log_probs,
)
from maopg.policy.encoders import JointEncoder, LocalEncoder, init_orthogonal

POLICY_HEAD_GAIN = 0.01
"""MAPPO's policy-head gain: near-uniform initial policy, so early exploration is broad."""


def _head(in_dim: int, out_dim: int, gain: float) -> nn.Linear:
    head = nn.Linear(in_dim, out_dim)
    init_orthogonal(head, gain)
    return head


class OptionPolicy(nn.Module, ABC):
    """A policy over joint options, conditioned on the continuing agents' running options."""

    option_counts: tuple[int, ...]

    @abstractmethod
    def distribution(
        self, obs: ObsBatch, choosing: Tensor, running: Tensor, available: Tensor
    ) -> JointOptionDistribution:
        """The conditional ``π̂(o^U | c, z)`` for each row.

        ``choosing`` ``bool [B, N]``, ``running`` ``int64 [B, N]``, ``available``
        ``bool [B, ΣK_i]`` — see :func:`maopg.policy.batch.stack_conditions`.
        """


class CentralizedPolicy(OptionPolicy):
    """Joint observation → logits over the product of all agents' option sets."""

    def __init__(self, spec: EnvSpec, **encoder_kw) -> None:
        super().__init__()
        self.option_counts = spec.option_counts
        self.encoder = JointEncoder(spec, **encoder_kw)
        self.head = _head(self.encoder.out_dim, math.prod(self.option_counts), POLICY_HEAD_GAIN)

    def joint_logits(self, obs: ObsBatch) -> Tensor:
        """``[B, K_0, ..., K_{N-1}]`` unconditioned joint logits."""
        return self.head(self.encoder(obs)).view(-1, *self.option_counts)

    def distribution(
        self, obs: ObsBatch, choosing: Tensor, running: Tensor, available: Tensor
    ) -> ConditionalJoint:
        return ConditionalJoint(self.joint_logits(obs), choosing, running, available)


class PartiallyCentralizedPolicy(OptionPolicy):
    """One policy per agent from its local observation, each with joint logits (paper §III-D).

    Agent i in ``U`` samples from its own joint logits conditioned on ``c`` with the other
    choosing agents marginalised out; the agents share options, not observations.
    """

    def __init__(self, spec: EnvSpec, **encoder_kw) -> None:
        super().__init__()
        self.option_counts = spec.option_counts
        joint = math.prod(self.option_counts)
        self.encoders = nn.ModuleList(
            LocalEncoder(spec, i, **encoder_kw) for i in range(spec.num_agents)
        )
        self.heads = nn.ModuleList(
            _head(enc.out_dim, joint, POLICY_HEAD_GAIN) for enc in self.encoders
        )

    def agent_joint_logits(self, obs: ObsBatch) -> list[Tensor]:
        """Agent i's joint logits ``[B, K_0, ..., K_{N-1}]`` from ``z^i``, for each i."""
        return [
            head(enc(obs)).view(-1, *self.option_counts)
            for enc, head in zip(self.encoders, self.heads, strict=True)
        ]

    def distribution(
        self, obs: ObsBatch, choosing: Tensor, running: Tensor, available: Tensor
    ) -> FactoredConditional:
        log_probs = partial_conditional_log_probs(
            self.agent_joint_logits(obs), choosing, running, available
        )
        return FactoredConditional(log_probs, choosing, running)


class JointQNetwork(nn.Module):
    """``Q(z, ·)`` over the flattened joint option: joint encoder (+ GRU) + linear head.

    Feed-forward: :meth:`forward` maps ``B`` observations to ``[B, ΠK_i]``. Recurrent: the GRU
    runs over one episode's decision points in order; :meth:`step` advances it by one point
    while acting, :meth:`sequence` runs whole padded episodes for training.
    """

    def __init__(
        self,
        spec: EnvSpec,
        hidden: int = 128,
        layers: int = 2,
        recurrent: bool = False,
        use_images: bool | None = None,
    ) -> None:
        super().__init__()
        self.option_counts = spec.option_counts
        self.encoder = JointEncoder(spec, hidden=hidden, layers=layers, use_images=use_images)
        self.gru = nn.GRU(hidden, hidden, batch_first=True) if recurrent else None
        self.head = nn.Linear(hidden, math.prod(self.option_counts))
        init_orthogonal(self.head, 1.0)

    @property
    def recurrent(self) -> bool:
        return self.gru is not None

    def initial_state(self, batch: int) -> Tensor | None:
        """Zero GRU state for ``batch`` fresh episodes (``None`` when feed-forward)."""
        if self.gru is None:
            return None
        return torch.zeros(1, batch, self.gru.hidden_size, device=self.head.weight.device)

    def forward(self, obs: ObsBatch) -> Tensor:
        if self.gru is not None:
            raise RuntimeError("the recurrent Q-network needs step() or sequence()")
        return self.head(self.encoder(obs))

    def step(self, obs: ObsBatch, state: Tensor | None) -> tuple[Tensor, Tensor | None]:
        """Q of one decision point per row, and the advanced GRU state."""
        if self.gru is None:
            return self.forward(obs), None
        out, state = self.gru(self.encoder(obs).unsqueeze(1), state)
        return self.head(out.squeeze(1)), state

    def sequence(self, obs: ObsBatch, batch: int, length: int) -> Tensor:
        """``[B, T, ΠK]`` for ``obs`` holding ``B`` episodes of ``T`` points, row-major, from zero
        state. Padding after an episode's end does not affect its earlier outputs (causal)."""
        features = self.encoder(obs).view(batch, length, -1)
        if self.gru is not None:
            features, _ = self.gru(features)
        return self.head(features)


class CentralCritic(nn.Module):
    """``V(z)`` on the joint observation (its own encoder: MAPPO keeps actor and critic apart)."""

    def __init__(self, spec: EnvSpec, **encoder_kw) -> None:
        super().__init__()
        self.encoder = JointEncoder(spec, **encoder_kw)
        self.head = _head(self.encoder.out_dim, 1, 1.0)

    def value(self, obs: ObsBatch) -> Tensor:
        """``[B]`` state values."""
        return self.head(self.encoder(obs)).squeeze(-1)

    def forward(self, obs: ObsBatch) -> Tensor:
        return self.value(obs)

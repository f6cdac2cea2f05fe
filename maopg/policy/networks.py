"""Option policies, the centralized critic and the joint Q-network (docs/DESIGN.md §4-§6).

:class:`OptionPolicy` is the seam a learner depends on: given a batch of joint observations and
the condition of each decision point (who chooses, what the others run, what is available) it
returns a distribution over joint options. The product categorical behind
:class:`CentralizedPolicy` is exact but grows as ``ΠK_i``; a factored or autoregressive
conditional policy for many agents would implement the same interface. With a recurrent
``memory`` (:class:`~maopg.policy.memory.MemoryDesign`) the policies and the critic carry a GRU
state over the decision points (:class:`EncodedPolicy`, :mod:`maopg.policy.memory`), for
partially observable tasks.

:class:`JointQNetwork` is Mac-DQN's acting network: a value for every joint option, acted on by
the conditional argmax of :mod:`maopg.policy.conditional`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import ClassVar

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
from maopg.policy.memory import FEED_FORWARD, MemoryDesign, OptionMemory

POLICY_HEAD_GAIN = 0.01
"""MAPPO's policy-head gain: near-uniform initial policy, so early exploration is broad."""


def _head(in_dim: int, out_dim: int, gain: float) -> nn.Linear:
    head = nn.Linear(in_dim, out_dim)
    init_orthogonal(head, gain)
    return head


class OptionPolicy(nn.Module, ABC):
    """A policy over joint options, conditioned on the continuing agents' running options.

    A feed-forward policy implements :meth:`distribution` only. A recurrent one
    (:attr:`recurrent`) carries a state from one decision point to the next: it acts through
    :meth:`step` and is trained through :meth:`sequence` (:mod:`maopg.policy.memory`); the
    learners and actors call :meth:`step` whatever the policy, with the state
    :meth:`initial_state` gave them (``None`` for a feed-forward one).
    """

    option_counts: tuple[int, ...]
    behaviour_version: ClassVar[int] = 1
    """The version of how the policy turns weights and observations into options: raise it
    with any change to that, so evaluations cached for the old behaviour are made again
    (:mod:`maopg.experiment.studies.cache`; ``tests/test_behaviour_versions.py`` fails for a
    method whose actions changed while its policy's version did not)."""

    @property
    def recurrent(self) -> bool:
        return False

    def initial_state(self, batch: int) -> Tensor | None:
        """The state of ``batch`` fresh episodes (``None``: the policy has no memory)."""
        return None

    @abstractmethod
    def distribution(
        self, obs: ObsBatch, choosing: Tensor, running: Tensor, available: Tensor
    ) -> JointOptionDistribution:
        """The conditional ``π̂(o^U | c, z)`` for each row.

        ``choosing`` ``bool [B, N]``, ``running`` ``int64 [B, N]``, ``available``
        ``bool [B, ΣK_i]`` — see :func:`maopg.policy.batch.stack_conditions`.
        """

    def step(
        self,
        obs: ObsBatch,
        choosing: Tensor,
        running: Tensor,
        available: Tensor,
        state: Tensor | None,
        starts: Tensor,
    ) -> tuple[JointOptionDistribution, Tensor | None]:
        """The conditional at one decision point per row given the ``state`` carried into it,
        and the state after it; ``starts`` ``bool [B]`` marks episode starts (state zeroed).
        A feed-forward policy ignores both and returns ``state`` unchanged."""
        return self.distribution(obs, choosing, running, available), state

    def sequence(
        self,
        obs: ObsBatch,
        choosing: Tensor,
        running: Tensor,
        available: Tensor,
        state: Tensor,
        starts: Tensor,
        valid: Tensor,
    ) -> JointOptionDistribution:
        """A recurrent policy's conditional along ``C`` chunks of ``L`` consecutive decision
        points (rows ``c * L + t`` of ``obs`` and the conditions), from the ``state``
        ``[C, ...]`` carried into each chunk, with ``starts`` ``bool [C, L]``; the result holds
        the rows where ``valid`` ``bool [C, L]`` (padding after a short chunk is dropped)."""
        raise TypeError(f"{type(self).__name__} is feed-forward: it has no sequence()")


class EncodedPolicy(OptionPolicy):
    """An :class:`OptionPolicy` made of encoders, an optional :class:`OptionMemory` after them
    (one slot per encoder) and a conditional head: the policies of this package.

    Subclasses say how observations become features (:meth:`encode`), how features become the
    conditional (:meth:`conditional`) and which memory slots a decision point advances
    (:meth:`advancing`); the feed-forward, stepped and chunked paths are written once here.
    """

    memory: OptionMemory | None
    """Set by every subclass (``None``: feed-forward)."""

    @property
    def recurrent(self) -> bool:
        return self.memory is not None

    def initial_state(self, batch: int) -> Tensor | None:
        return None if self.memory is None else self.memory.initial_state(batch)

    @abstractmethod
    def encode(self, obs: ObsBatch) -> list[Tensor]:
        """One ``[B, F]`` feature tensor per encoder (per memory slot)."""

    @abstractmethod
    def conditional(
        self, features: list[Tensor], choosing: Tensor, running: Tensor, available: Tensor
    ) -> JointOptionDistribution:
        """The conditional from the (remembered) features."""

    def advancing(self, choosing: Tensor) -> Tensor | None:
        """``bool [B, S]``: which memory slots a decision point advances (``None``: all)."""
        return None

    def distribution(
        self, obs: ObsBatch, choosing: Tensor, running: Tensor, available: Tensor
    ) -> JointOptionDistribution:
        if self.memory is not None:
            raise RuntimeError("a recurrent policy acts through step() and sequence()")
        return self.conditional(self.encode(obs), choosing, running, available)

    def step(
        self,
        obs: ObsBatch,
        choosing: Tensor,
        running: Tensor,
        available: Tensor,
        state: Tensor | None,
        starts: Tensor,
    ) -> tuple[JointOptionDistribution, Tensor | None]:
        if self.memory is None:
            return self.distribution(obs, choosing, running, available), state
        if state is None:
            raise ValueError("a recurrent policy needs the state carried into the point")
        features, state = self.memory.step(
            self.encode(obs),
            state,
            starts,
            self.advancing(choosing),
            self.memory.history(choosing, running),
        )
        return self.conditional(features, choosing, running, available), state

    def sequence(
        self,
        obs: ObsBatch,
        choosing: Tensor,
        running: Tensor,
        available: Tensor,
        state: Tensor,
        starts: Tensor,
        valid: Tensor,
    ) -> JointOptionDistribution:
        if self.memory is None:
            return super().sequence(obs, choosing, running, available, state, starts, valid)
        advancing = self.advancing(choosing)
        if advancing is not None:
            advancing = advancing.view(*starts.shape, -1)
        features = self.memory.sequence(
            self.encode(obs), state, starts, advancing, self.memory.history(choosing, running)
        )
        rows = valid.flatten()
        return self.conditional(
            [x[rows] for x in features], choosing[rows], running[rows], available[rows]
        )


class CentralizedPolicy(EncodedPolicy):
    """Joint observation → logits over the product of all agents' option sets.

    A recurrent ``memory``: a GRU after the encoder, one joint state advancing at every decision
    point.
    """

    def __init__(
        self,
        spec: EnvSpec,
        *,
        memory: MemoryDesign = FEED_FORWARD,
        **encoder_kw,
    ) -> None:
        super().__init__()
        self.option_counts = spec.option_counts
        self.encoder = JointEncoder(spec, **encoder_kw)
        self.head = _head(self.encoder.out_dim, math.prod(self.option_counts), POLICY_HEAD_GAIN)
        self.memory = memory.build(spec.option_counts, self.encoder.out_dim, 1)

    def joint_logits(self, obs: ObsBatch) -> Tensor:
        """``[B, K_0, ..., K_{N-1}]`` unconditioned joint logits (feed-forward)."""
        return self._logits(self.encode(obs)[0])

    def _logits(self, features: Tensor) -> Tensor:
        return self.head(features).view(-1, *self.option_counts)

    def encode(self, obs: ObsBatch) -> list[Tensor]:
        return [self.encoder(obs)]

    def conditional(
        self, features: list[Tensor], choosing: Tensor, running: Tensor, available: Tensor
    ) -> ConditionalJoint:
        return ConditionalJoint(self._logits(features[0]), choosing, running, available)


class PartiallyCentralizedPolicy(EncodedPolicy):
    """One policy per agent from its local observation, each with joint logits (paper §III-D).

    Agent i in ``U`` samples from its own joint logits conditioned on ``c`` with the other
    choosing agents marginalised out; the agents share options, not observations.
    A recurrent ``memory``: one GRU state per agent, advancing only at that agent's own
    decisions.
    """

    def __init__(
        self,
        spec: EnvSpec,
        *,
        memory: MemoryDesign = FEED_FORWARD,
        **encoder_kw,
    ) -> None:
        super().__init__()
        self.option_counts = spec.option_counts
        joint = math.prod(self.option_counts)
        self.encoders = nn.ModuleList(
            LocalEncoder(spec, i, **encoder_kw) for i in range(spec.num_agents)
        )
        self.heads = nn.ModuleList(
            _head(enc.out_dim, joint, POLICY_HEAD_GAIN) for enc in self.encoders
        )
        size = self.encoders[0].out_dim
        self.memory = memory.build(spec.option_counts, size, spec.num_agents)

    def agent_joint_logits(self, obs: ObsBatch) -> list[Tensor]:
        """Agent i's joint logits ``[B, K_0, ..., K_{N-1}]`` from ``z^i``, for each i
        (feed-forward)."""
        return self._agent_logits(self.encode(obs))

    def _agent_logits(self, features: list[Tensor]) -> list[Tensor]:
        return [
            head(x).view(-1, *self.option_counts)
            for x, head in zip(features, self.heads, strict=True)
        ]

    def encode(self, obs: ObsBatch) -> list[Tensor]:
        return [enc(obs) for enc in self.encoders]

    def advancing(self, choosing: Tensor) -> Tensor:
        return choosing.bool()

    def conditional(
        self, features: list[Tensor], choosing: Tensor, running: Tensor, available: Tensor
    ) -> FactoredConditional:
        log_probs = partial_conditional_log_probs(
            self._agent_logits(features), choosing, running, available
        )
        return FactoredConditional(log_probs, choosing, running)


class JointQNetwork(nn.Module):
    """``Q(z, ·)`` over the flattened joint option: joint encoder (+ GRU) + linear head.

    Feed-forward: :meth:`forward` maps ``B`` observations to ``[B, ΠK_i]``. Recurrent: the GRU
    runs over one episode's decision points in order; :meth:`step` advances it by one point
    while acting, :meth:`sequence` runs whole padded episodes for training.
    """

    behaviour_version: ClassVar[int] = 1
    """As :attr:`OptionPolicy.behaviour_version`."""

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
    """``V(z)`` on the joint observation (its own encoder: MAPPO keeps actor and critic apart).

    A recurrent ``memory``: a GRU after the encoder, one joint state advancing at every decision
    point, used through :meth:`step` and :meth:`sequence` like a recurrent policy's.
    """

    def __init__(
        self,
        spec: EnvSpec,
        *,
        memory: MemoryDesign = FEED_FORWARD,
        **encoder_kw,
    ) -> None:
        super().__init__()
        self.encoder = JointEncoder(spec, **encoder_kw)
        self.head = _head(self.encoder.out_dim, 1, 1.0)
        self.memory = memory.build(spec.option_counts, self.encoder.out_dim, 1)

    @property
    def recurrent(self) -> bool:
        return self.memory is not None

    def initial_state(self, batch: int) -> Tensor | None:
        return None if self.memory is None else self.memory.initial_state(batch)

    def value(self, obs: ObsBatch) -> Tensor:
        """``[B]`` state values (feed-forward)."""
        if self.memory is not None:
            raise RuntimeError("a recurrent critic values through step() and sequence()")
        return self._value(self.encoder(obs))

    def _value(self, features: Tensor) -> Tensor:
        return self.head(features).squeeze(-1)

    def forward(self, obs: ObsBatch) -> Tensor:
        return self.value(obs)

    def step(
        self,
        obs: ObsBatch,
        state: Tensor | None,
        starts: Tensor,
        choosing: Tensor,
        running: Tensor,
    ) -> tuple[Tensor, Tensor | None]:
        """``[B]`` values of one decision point per row and the state after it (as
        :meth:`OptionPolicy.step`; the conditions feed a memory of the option history only)."""
        if self.memory is None:
            return self.value(obs), state
        if state is None:
            raise ValueError("a recurrent critic needs the state carried into the point")
        history = self.memory.history(choosing, running)
        features, state = self.memory.step([self.encoder(obs)], state, starts, None, history)
        return self._value(features[0]), state

    def sequence(
        self,
        obs: ObsBatch,
        state: Tensor,
        starts: Tensor,
        valid: Tensor,
        choosing: Tensor,
        running: Tensor,
    ) -> Tensor:
        """Values along chunks of consecutive points, the ``valid`` rows (as
        :meth:`OptionPolicy.sequence`)."""
        if self.memory is None:
            raise TypeError("a feed-forward critic has no sequence()")
        history = self.memory.history(choosing, running)
        features = self.memory.sequence([self.encoder(obs)], state, starts, None, history)
        return self._value(features[0][valid.flatten()])

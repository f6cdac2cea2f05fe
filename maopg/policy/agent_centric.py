"""ACAC's networks (Agent-Centric Actor-Critic; Jung et al., ICML 2025): agent-centric history
encoders that advance only at each agent's own decisions, one actor per agent, and a critic
that attends across the agents' encodings.

- **Input of agent i** at its decision: its own observation (its vector, and its camera through
  a CNN of its own when the run has images) and the event's time, embedded as
  ``(sin τ, cos τ)`` with ``τ`` = ticks since reset + 1 (the published embedding: a sinusoidal
  table of width 2, whose only frequency is 1, indexed by the step at which the observation was
  received). Then Linear → leaky ReLU → Linear → leaky ReLU (width ``width``, 32 published).
- **Actor i** (no parameter sharing): a GRU cell over those inputs, advanced only where agent i
  chooses, then Linear → leaky ReLU → LayerNorm → Linear to its options' logits.
- **Critic**: a GRU encoder per agent of the same form (its own weights), advanced at the
  agent's own decisions; its latest state is the agent's token. A learned embedding of the
  agent's index is added, one pre-LayerNorm transformer block (``heads`` heads, a 4× MLP with
  tanh-approximated GELU, no causal mask) and a final LayerNorm follow, then the mean over
  agents and :class:`PopArt`'s linear head.

Choices where the paper leaves one open, taken from the authors' public code: Xavier-uniform
initialisation with the leaky-ReLU gain for hidden layers and gain 1 for outputs, zero biases;
GRUs and the transformer at torch's defaults (the transformer's weights drawn from N(0, 0.02)
as GPT-2's). Not taken: the transformer's dropout (0.1, a GPT-2 default left on in that code,
in the target critic's passes too) — it would make the critic's values random, and the paper
describes none.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
from torch import Tensor, nn

from maopg.env.contract import EnvSpec
from maopg.policy.batch import ObsBatch, vector_slices
from maopg.policy.conditional import FactoredConditional, agent_masks
from maopg.policy.encoders import NatureCNN
from maopg.policy.networks import OptionPolicy

LEAKY_GAIN = nn.init.calculate_gain("leaky_relu")


def time_embedding(ticks: Tensor) -> Tensor:
    """``[..., 2]``: ``(sin τ, cos τ)`` of ``τ = ticks + 1``, the event time of an observation
    received ``ticks`` ticks after reset (the reset observation has ``τ = 1``)."""
    tau = ticks.to(torch.float32) + 1.0
    return torch.stack((torch.sin(tau), torch.cos(tau)), dim=-1)


def linear(in_dim: int, out_dim: int, gain: float) -> nn.Linear:
    """A linear layer, Xavier-uniform with ``gain`` and a zero bias (the MacroMARL and ACAC
    networks' initialisation)."""
    layer = nn.Linear(in_dim, out_dim)
    nn.init.xavier_uniform_(layer.weight, gain=gain)
    nn.init.zeros_(layer.bias)
    return layer


def leaky_mlp(in_dim: int, width: int) -> nn.Sequential:
    """Linear → leaky ReLU → Linear → leaky ReLU, ``width`` wide: the input layers of the ACAC
    and MacroMARL networks."""
    return nn.Sequential(
        linear(in_dim, width, LEAKY_GAIN),
        nn.LeakyReLU(),
        linear(width, width, LEAKY_GAIN),
        nn.LeakyReLU(),
    )


class AgentInput(nn.Module):
    """Agent ``agent``'s own observation and (``embed_time``) its event time → ``[B, width]``
    features."""

    def __init__(
        self, spec: EnvSpec, agent: int, width: int, cnn_features: int, embed_time: bool = True
    ) -> None:
        super().__init__()
        self.agent = agent
        self.embed_time = embed_time
        self.columns = vector_slices(spec)[agent]
        self.cnn = NatureCNN.of_spec(spec, cnn_features) if spec.image_shape is not None else None
        in_dim = self.columns.stop - self.columns.start + (2 if embed_time else 0)
        in_dim += cnn_features if self.cnn is not None else 0
        self.mlp = leaky_mlp(in_dim, width)

    def forward(self, obs: ObsBatch) -> Tensor:
        parts = [obs.vectors[:, self.columns]]
        if self.embed_time:
            if obs.ticks is None:
                raise ValueError("embedding event times needs the points' ticks (ObsBatch.ticks)")
            parts.append(time_embedding(obs.ticks))
        if self.cnn is not None:
            images = obs.dense_images()
            if images is None:
                raise ValueError("this network reads images but the batch has none")
            parts.append(self.cnn(images[:, self.agent]))
        return self.mlp(torch.cat(parts, dim=-1))


def advance(
    cells: Sequence[nn.Module], inputs: Sequence[Tensor], state: Tensor, where: Tensor
) -> Tensor:
    """``state`` ``[B, N, W]`` with agent i's GRU cell applied to ``inputs[i]`` ``[B, W]`` where
    ``where[:, i]``; elsewhere it is kept."""
    stepped = torch.stack(
        [cell(x, state[:, i]) for i, (cell, x) in enumerate(zip(cells, inputs, strict=True))], 1
    )
    return torch.where(where.bool().unsqueeze(-1), stepped, state)


def scan(
    cells: Sequence[nn.GRUCell],
    inputs: Sequence[Tensor],
    choosing: Tensor,
    starts: Tensor,
    state: Tensor,
) -> Tensor:
    """The states ``[T, B, N, W]`` after each of ``T`` time-major points of ``B`` sequences:
    ``inputs[i]`` ``[T * B, W]``, ``choosing`` ``bool [T, B, N]``, ``starts`` ``bool [T, B]``
    (state zeroed there), from ``state`` ``[B, N, W]``; as :func:`advance` point by point.

    Each agent's cell runs once over its own events, not once per point of the team: a
    sequence's points split at its starts into segments, agent i's events in each segment are
    gathered into a padded ``[K, segments, W]`` batch that one :func:`torch.gru` call (the
    cell's own weights) runs through, and every point reads back the state after the agent's
    latest event of its segment (the segment's initial state before its first). The GRU's
    arithmetic is the cell's, so the states agree with stepping to rounding (on a GPU without
    cuDNN, whose RNNs may compute in TF32)."""
    steps, batch = choosing.shape[:2]
    device = choosing.device
    times = torch.arange(steps, device=device).view(-1, 1).expand(steps, batch)
    # Segment of each point: its sequence's segment count so far, offset per sequence.
    in_sequence = starts.long().cumsum(0)
    per_sequence = in_sequence[-1] + 1
    offsets = per_sequence.cumsum(0) - per_sequence
    segment = offsets + in_sequence
    segments = int(per_sequence.sum())
    # The point where each point's segment began (-1: before any start of its sequence).
    began = torch.where(starts, times, torch.full_like(times, -1)).cummax(0).values
    states = []
    for i, cell in enumerate(cells):
        mine = choosing[..., i]
        count = mine.long().cumsum(0)
        before = (count - mine.long()).gather(0, began.clamp(min=0))
        events = count - torch.where(began >= 0, before, torch.zeros_like(before))
        length = int(events.max()) if events.numel() else 0
        # A sequence's first segment (before its first start) continues ``state``.
        initial = state.new_zeros(segments, cell.hidden_size).index_put((offsets,), state[:, i])
        table = initial.unsqueeze(0)
        if length:
            rows = mine.flatten()
            where = ((events.flatten() - 1)[rows], segment.flatten()[rows])
            x = inputs[i]
            padded = x.new_zeros(length, segments, x.shape[-1]).index_put(where, x[rows])
            weights = [cell.weight_ih, cell.weight_hh, cell.bias_ih, cell.bias_hh]
            # Off cuDNN: its RNNs may compute in TF32, where the acting cells stay in fp32.
            with torch.backends.cudnn.flags(enabled=False):
                out, _ = torch.gru(
                    padded, initial.unsqueeze(0), weights, True, 1, 0.0, cell.training, False, False
                )
            table = torch.cat((table, out))
        states.append(table[events, segment])
    return torch.stack(states, 2)


class AgentCentricPolicy(OptionPolicy):
    """One recurrent actor per agent (module docstring); its state ``[B, N, width]``.
    ``embed_time`` and ``head_norm`` (the event time in the input, the LayerNorm before the
    output) are ACAC's; without them it is the MacroMARL actors'
    (:mod:`maopg.learner.mac_iaicc`)."""

    behaviour_version = 1

    def __init__(
        self,
        spec: EnvSpec,
        *,
        width: int = 32,
        cnn_features: int = 256,
        embed_time: bool = True,
        head_norm: bool = True,
    ) -> None:
        super().__init__()
        self.option_counts = spec.option_counts
        self.width = width
        n = spec.num_agents
        self.inputs = nn.ModuleList(
            AgentInput(spec, i, width, cnn_features, embed_time) for i in range(n)
        )
        self.cells = nn.ModuleList(nn.GRUCell(width, width) for _ in range(n))
        self.heads = nn.ModuleList(
            nn.Sequential(
                linear(width, width, LEAKY_GAIN),
                nn.LeakyReLU(),
                *([nn.LayerNorm(width)] if head_norm else []),
                linear(width, k, 1.0),
            )
            for k in spec.option_counts
        )

    @property
    def recurrent(self) -> bool:
        return True

    def initial_state(self, batch: int) -> Tensor:
        return torch.zeros(batch, len(self.option_counts), self.width)

    def distribution(
        self, obs: ObsBatch, choosing: Tensor, running: Tensor, available: Tensor
    ) -> FactoredConditional:
        """The conditional from a fresh memory (as at an episode's first decision)."""
        state = self.initial_state(len(obs)).to(obs.vectors.device)
        starts = torch.ones(len(obs), dtype=torch.bool, device=obs.vectors.device)
        return self.step(obs, choosing, running, available, state, starts)[0]

    def step(
        self,
        obs: ObsBatch,
        choosing: Tensor,
        running: Tensor,
        available: Tensor,
        state: Tensor | None,
        starts: Tensor,
    ) -> tuple[FactoredConditional, Tensor]:
        assert state is not None
        state = state.masked_fill(starts.view(-1, 1, 1), 0.0)
        state = advance(self.cells, [net(obs) for net in self.inputs], state, choosing)
        return self.heads_at(state, choosing, running, available), state

    def heads_at(
        self, state: Tensor, choosing: Tensor, running: Tensor, available: Tensor
    ) -> FactoredConditional:
        """The conditional of actors in ``state`` ``[B, N, width]`` (each agent's after its
        latest decision): a choosing agent over its available options, a continuing one fixed
        at its running option."""
        masks = agent_masks(choosing, running, available, self.option_counts)
        log_probs = [
            torch.log_softmax(head(state[:, i]).masked_fill(~mask, -math.inf), dim=-1)
            for i, (head, mask) in enumerate(zip(self.heads, masks, strict=True))
        ]
        return FactoredConditional(log_probs, choosing, running)


class PopArt(nn.Module):
    """A linear value head whose output is kept in normalised units while the return
    statistics move (van Hasselt et al. 2016): ``update`` re-estimates the debiased mean and
    standard deviation of the targets and rescales the weights so every output, denormalised,
    stays what it was."""

    def __init__(self, in_dim: int, beta: float = 0.99999, eps: float = 1e-5) -> None:
        super().__init__()
        self.linear = nn.Linear(in_dim, 1)
        self.beta, self.eps = beta, eps
        self.register_buffer("mean", torch.zeros(()))
        self.register_buffer("mean_sq", torch.zeros(()))
        self.register_buffer("debias", torch.zeros(()))

    def forward(self, x: Tensor) -> Tensor:
        return self.linear(x).squeeze(-1)

    def stats(self) -> tuple[Tensor, Tensor]:
        """The debiased mean and standard deviation (the variance floored at 1e-2)."""
        debias = self.debias.clamp(min=self.eps)
        mean = self.mean / debias
        variance = (self.mean_sq / debias - mean.square()).clamp(min=1e-2)
        return mean, variance.sqrt()

    def normalize(self, returns: Tensor) -> Tensor:
        mean, std = self.stats()
        return (returns - mean) / std

    def denormalize(self, values: Tensor) -> Tensor:
        mean, std = self.stats()
        return values * std + mean

    @torch.no_grad()
    def update(self, returns: Tensor) -> None:
        """Fold the batch ``returns`` into the statistics, preserving every output."""
        old_mean, old_std = self.stats()
        b = self.beta
        self.mean.mul_(b).add_((1 - b) * returns.mean())
        self.mean_sq.mul_(b).add_((1 - b) * returns.square().mean())
        self.debias.mul_(b).add_(1 - b)
        new_mean, new_std = self.stats()
        self.linear.weight.mul_(old_std / new_std)
        self.linear.bias.mul_(old_std).add_(old_mean - new_mean).div_(new_std)


class AgentCentricCritic(nn.Module):
    """The attention critic over the agents' own histories (module docstring); its state
    ``[B, N, width]`` holds each agent's latest encoding."""

    def __init__(
        self,
        spec: EnvSpec,
        *,
        width: int = 32,
        heads: int = 2,
        cnn_features: int = 256,
        popart_beta: float = 0.99999,
    ) -> None:
        super().__init__()
        n = spec.num_agents
        self.width = width
        self.inputs = nn.ModuleList(AgentInput(spec, i, width, cnn_features) for i in range(n))
        self.cells = nn.ModuleList(nn.GRUCell(width, width) for _ in range(n))
        self.agent_embedding = nn.Parameter(torch.randn(n, width) * 0.02)
        self.norm_attention = nn.LayerNorm(width)
        self.attention = nn.MultiheadAttention(width, heads, batch_first=True)
        self.norm_mlp = nn.LayerNorm(width)
        self.mlp = nn.Sequential(
            nn.Linear(width, 4 * width), nn.GELU(approximate="tanh"), nn.Linear(4 * width, width)
        )
        self.norm_out = nn.LayerNorm(width)
        for linear in (self.attention.out_proj, self.mlp[0], self.mlp[2]):
            nn.init.normal_(linear.weight, std=0.02)
            nn.init.zeros_(linear.bias)
        nn.init.normal_(self.attention.in_proj_weight, std=0.02)
        nn.init.zeros_(self.attention.in_proj_bias)
        self.value_head = PopArt(width, beta=popart_beta)

    def initial_state(self, batch: int) -> Tensor:
        return torch.zeros(batch, len(self.cells), self.width)

    def step(
        self, obs: ObsBatch, choosing: Tensor, state: Tensor, starts: Tensor
    ) -> tuple[Tensor, Tensor]:
        """Normalised values ``[B]`` at one decision point per row and the state after it;
        each agent's encoder advances where it chooses (every agent at an episode's start)."""
        state = state.masked_fill(starts.view(-1, 1, 1), 0.0)
        state = advance(self.cells, [net(obs) for net in self.inputs], state, choosing)
        return self.value(state), state

    def value(self, tokens: Tensor) -> Tensor:
        """Normalised values ``[B]`` of the agents' encodings ``[B, N, width]``."""
        x = tokens + self.agent_embedding
        h = self.norm_attention(x)
        x = x + self.attention(h, h, h, need_weights=False)[0]
        x = x + self.mlp(self.norm_mlp(x))
        return self.value_head(self.norm_out(x).mean(dim=1))

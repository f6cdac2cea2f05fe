"""The autoregressive conditional policy: the paper's conditional, factored by the chain rule.

The product categorical (:class:`~maopg.policy.networks.CentralizedPolicy`) holds a logit for
every joint option, ``ΠK_i`` per decision point: 54 for Tool Delivery, 2.2 million for a team
of eight. This policy instead writes the same conditional as a product of one small factor per
choosing agent ``u_1 < u_2 < ... < u_k`` (the choosing agents in the spec's agent order):

    π(o^U | c, z) = Π_k π(o^{u_k} | z, c, o^{u_1}, ..., o^{u_{k-1}})

Each factor is one shared head over ``[features(z), features(z^{u_k}), identity of the agent,
who chooses, what every other agent is known to do]``: the joint observation's features and
the agent's own observation's, then a continuing agent's running option, an earlier choosing
agent's drawn option, or "not decided yet" for the later ones. The chain rule is exact, so
this represents every conditional the product categorical can (a correlated joint too:
``tests/policy/test_autoregressive.py`` fits one), at a cost linear in the number of agents.

**Why this order.** Any fixed order is exact; the spec's order is deterministic (the same joint
is scored the same way at collection and update), needs no extra input to say what the order
was, and lets a batch whose rows have different ``U`` run each agent's factor in one pass.

**Shapes.** Options of agent ``i`` are the first ``K_i`` outputs of the shared head (which has
``max K_i``); availability masks remove the rest. ``log_prob`` of a recorded joint runs every
agent's factor in one batched pass (teacher forcing); ``sample`` and ``mode`` run ``|U|`` small
sequential steps (each agent that chooses in some row of the batch).

**Entropy.** The entropy of the joint has no closed form here; :meth:`entropy` is the chain-rule
entropy along a joint, ``Σ_k H(π(·| z, c, o^{u_<k}))``: along the joint last scored by
:meth:`log_prob` (MAPPO scores the recorded joint first, which the behaviour policy drew, so
this is an unbiased estimate of the joint entropy), else along the greedy prefix. :meth:`mode`
is the greedy decode (argmax factor by factor), not the joint argmax.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch
from torch import Tensor, nn

from maopg.env.contract import EnvSpec
from maopg.policy.batch import ObsBatch
from maopg.policy.conditional import agent_masks, draw_multinomial
from maopg.policy.encoders import JointEncoder, LocalEncoder, init_orthogonal
from maopg.policy.memory import FEED_FORWARD, MemoryDesign
from maopg.policy.networks import POLICY_HEAD_GAIN, EncodedPolicy


class AutoregressivePolicy(EncodedPolicy):
    """Observations → features; one shared factor head per choosing agent (module doc).

    Factor ``u_k`` reads the joint features of ``z`` and the features of agent ``u_k``'s own
    observation ``z^{u_k}`` (one :class:`~maopg.policy.encoders.LocalEncoder` per agent): both
    are functions of ``z``, so this is still the paper's ``π(o^{u_k} | z, c, o^{u_<k})``, and
    the chain rule stays exact. Why the agent's own features: with the joint features alone,
    one shared head must pull each agent's view out of a single summary of the whole team,
    and on Tool Delivery the policy could then settle where no Fetch ever passes: on one seed of
    five at the paper's size (return −150) and on one of three in a team of eight (150, no tool
    delivered), where ``partial-ar``, reading local features only, never did.

    A recurrent ``memory``: a GRU per encoder — the joint state advances at every decision
    point, agent ``i``'s own state only where agent ``i`` chooses (as in
    :class:`PartialFactoredPolicy`).
    """

    sees_joint = True
    """Whether a factor reads the joint features beside its agent's own."""
    sees_earlier_choices = True
    """Whether a factor sees the options drawn before it in the step (the chain rule)."""

    def __init__(
        self,
        spec: EnvSpec,
        *,
        hidden: int = 128,
        layers: int = 2,
        memory: MemoryDesign = FEED_FORWARD,
        **encoder_kw,
    ) -> None:
        super().__init__()
        self.option_counts = spec.option_counts
        n = len(self.option_counts)
        encoder_kw |= {"hidden": hidden, "layers": layers}
        self.encoder = JointEncoder(spec, **encoder_kw) if self.sees_joint else None
        self.encoders = nn.ModuleList(LocalEncoder(spec, i, **encoder_kw) for i in range(n))
        size = self.encoders[0].out_dim
        width = size + (self.encoder.out_dim if self.encoder is not None else 0)
        # Agent j's known option as a one-hot over K_j + 1 slots, the last meaning "not decided".
        slots = [k + 1 for k in self.option_counts]
        self.register_buffer("offsets", torch.tensor([0, *slots[:-1]]).cumsum(0), persistent=False)
        self.register_buffer("undecided", torch.tensor(self.option_counts), persistent=False)
        self.context = sum(slots)
        self.factor = nn.Sequential(
            nn.Linear(width + 2 * n + self.context, hidden),
            nn.ReLU(),
        )
        init_orthogonal(self.factor, math.sqrt(2.0))
        self.head = nn.Linear(hidden, max(self.option_counts))
        init_orthogonal(self.head, POLICY_HEAD_GAIN)
        memory_slots = n + (self.encoder is not None)
        self.memory = memory.build(spec.option_counts, size, memory_slots)

    def factor_logits(
        self, features: Tensor, choosing: Tensor, known: Tensor, agents: Tensor
    ) -> Tensor:
        """``[B, A, max K]`` logits of the factors of ``agents`` (``int64 [A]``).

        ``features`` ``[B, N, F]``: what each agent's factor reads (:meth:`conditional`).
        ``known`` ``int64 [B, A, N]``: for factor ``a``, what each agent is known to do (its
        option, or its ``K_j`` for "not decided yet").
        """
        b, a, n = known.shape
        one_hot = torch.zeros(b, a, self.context, device=known.device)
        one_hot.scatter_(-1, known + self.offsets, 1.0)
        identity = nn.functional.one_hot(agents.to(known.device), n).float().expand(b, a, n)
        inputs = torch.cat(
            [
                features[:, agents],
                identity,
                choosing.float().unsqueeze(1).expand(b, a, n),
                one_hot,
            ],
            dim=-1,
        )
        return self.head(self.factor(inputs))

    def encode(self, obs: ObsBatch) -> list[Tensor]:
        """The joint features first (if read), then every agent's own."""
        local = [encoder(obs) for encoder in self.encoders]
        return local if self.encoder is None else [self.encoder(obs), *local]

    def advancing(self, choosing: Tensor) -> Tensor:
        """The joint slot at every point; agent ``i``'s own slot only where ``i`` chooses."""
        own = choosing.bool()
        if self.encoder is None:
            return own
        return torch.cat([torch.ones_like(own[:, :1]), own], dim=1)

    def conditional(
        self, features: list[Tensor], choosing: Tensor, running: Tensor, available: Tensor
    ) -> AutoregressiveConditional:
        """Stack what each factor reads, ``[B, N, F]``: its agent's own features, after the
        joint ones where the policy reads them."""
        if self.encoder is None:
            stacked = torch.stack(features, dim=1)
        else:
            joint, *local = features
            own = torch.stack(local, dim=1)
            stacked = torch.cat([joint.unsqueeze(1).expand(-1, own.shape[1], -1), own], dim=-1)
        return AutoregressiveConditional(self, stacked, choosing, running, available)


class PartialFactoredPolicy(AutoregressivePolicy):
    """The partially centralized policy (paper §III-D) at any team size: each choosing agent
    draws from its own factor ``π_i(o^i | z^i, c)`` — its local observation, who chooses and
    what the continuing agents run — and not from the others' draws.

    The paper's partial policy gives every agent joint logits over all ``ΠK`` options and
    marginalises the other choosing agents out, so what agent ``i`` draws from is exactly such
    a marginal; this parameterises that marginal directly, with one shared factor head (and the
    agent's identity) over per-agent encoders, so its cost is linear in the team size. As in the
    paper the choosing agents draw independently given ``c``: neither the joint features nor
    the earlier draws are read, and the entropy along a joint is the exact joint entropy.
    A recurrent ``memory``: one state per agent, advancing only at that agent's own decisions.
    """

    sees_joint = False
    sees_earlier_choices = False


class AutoregressiveConditional:
    """``π(o^U | c, z)`` of an :class:`AutoregressivePolicy` for a batch (module docstring);
    a :class:`~maopg.policy.conditional.JointOptionDistribution`."""

    def __init__(
        self,
        policy: AutoregressivePolicy,
        features: Tensor,
        choosing: Tensor,
        running: Tensor,
        available: Tensor,
    ) -> None:
        self.policy = policy
        self.features = features
        self.choosing = choosing.bool()
        self.running = running
        counts = policy.option_counts
        masks = agent_masks(self.choosing, running, available, counts)
        width = max(counts)
        # [B, N, max K]: agent i's admissible options, padded with False past K_i.
        self.masks = torch.stack(
            [nn.functional.pad(m, (0, width - m.shape[-1]), value=False) for m in masks], dim=1
        )
        self._scored: Tensor | None = None
        """Per-factor log-probabilities ``[B, N, max K]`` along the joint last scored."""

    # ------------------------------------------------------------------ factors
    def _known(self, joint: Tensor, agents: Tensor) -> Tensor:
        """``int64 [B, A, N]``: what factor ``a`` (agent ``agents[a]``) knows of each agent —
        a continuing agent's running option, an earlier choosing agent's ``joint`` entry,
        "not decided" (``K_j``) for itself and later choosing agents."""
        n = self.choosing.shape[-1]
        device = self.choosing.device
        earlier = torch.arange(n, device=device).unsqueeze(0) < agents.to(device).unsqueeze(1)
        if not self.policy.sees_earlier_choices:
            earlier = torch.zeros_like(earlier)
        known = ~self.choosing.unsqueeze(1) | (self.choosing.unsqueeze(1) & earlier)
        values = torch.where(self.choosing, joint, self.running).unsqueeze(1)
        return torch.where(known, values, self.policy.undecided)

    def _log_softmax(self, logits: Tensor, agents: Tensor) -> Tensor:
        """Masked log-softmax of factor logits ``[B, A, max K]`` for ``agents``. A continuing
        agent's lane holds only its running option, so it gets log-probability 0 there."""
        mask = self.masks[:, agents]
        return torch.log_softmax(logits.masked_fill(~mask, -math.inf), dim=-1)

    def decode(self, pick: Callable[[Tensor], Tensor]) -> Tensor:
        """Draw the choosing agents one after another with ``pick(log_probs [B, max K])``."""
        joint = self.running.clone()
        n = joint.shape[-1]
        for i in range(n):
            rows = self.choosing[:, i]
            if not bool(rows.any()):
                continue
            agent = torch.tensor([i], device=joint.device)
            logits = self.policy.factor_logits(
                self.features, self.choosing, self._known(joint, agent), agent
            )
            choice = pick(self._log_softmax(logits, agent)[:, 0])
            joint[:, i] = torch.where(rows, choice, joint[:, i])
        return joint

    def factor_log_probs(self, joint: Tensor) -> Tensor:
        """``[B, N, max K]`` every agent's factor along ``joint``, in one batched pass (teacher
        forcing); rows of continuing agents are their one-hot (log-probability 0). Kept as the
        joint last scored, which :meth:`entropy` reads."""
        joint = torch.where(self.choosing, joint, self.running)
        agents = torch.arange(joint.shape[-1], device=joint.device)
        logits = self.policy.factor_logits(
            self.features, self.choosing, self._known(joint, agents), agents
        )
        self._scored = self._log_softmax(logits, agents)
        return self._scored

    # ------------------------------------------------------------------ the protocol
    def sample(self, generator: torch.Generator | None = None) -> Tensor:
        return self.decode(lambda lp: draw_multinomial(lp.exp(), generator))

    def mode(self) -> Tensor:
        return self.decode(lambda lp: lp.argmax(dim=-1))

    def log_prob(self, joint: Tensor) -> Tensor:
        """``log π`` of ``int64 [B, N]`` joints: the sum of the choosing agents' factors."""
        joint = torch.where(self.choosing, joint, self.running)
        picked = self.factor_log_probs(joint).gather(-1, joint.unsqueeze(-1)).squeeze(-1)
        return picked.masked_fill(~self.choosing, 0.0).sum(dim=-1)

    def entropy(self) -> Tensor:
        """Chain-rule entropy along the joint last scored (else the greedy one): module doc."""
        scored = self._scored if self._scored is not None else self.factor_log_probs(self.mode())
        finite = torch.isfinite(scored)
        per_agent = -(scored.exp() * scored.masked_fill(~finite, 0.0)).sum(dim=-1)
        return per_agent.masked_fill(~self.choosing, 0.0).sum(dim=-1)

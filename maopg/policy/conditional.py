"""Conditional distributions over joint options (docs/DESIGN.md §4, paper §III-B..D): tensor math.

At a decision point only the agents in ``U`` (``choosing``) pick a new option; every other agent
``j`` keeps its running option ``c_j``. The paper's conditional policy is the joint categorical
restricted to the *slice* where ``o_j = c_j`` for all ``j ∉ U``, renormalised:

    log π̂(o^U | c, z) = logit[o^U, c] − logsumexp(logit[·, c])

Unavailable options of choosing agents are removed (−inf) *before* conditioning, so they get
probability 0 and the remaining ones are renormalised among themselves.

Implementation: the slice is the outer AND of one boolean mask per agent — ``available_i`` for a
choosing agent, the one-hot of ``c_i`` for a continuing one — so a single ``masked_fill`` and a
``log_softmax`` over the flattened joint give the exact conditional for every row of a batch at
once, whatever ``U`` each row has (sync: all choose; async: any subset). The cost is ``B·ΠK_i``,
which is what the product categorical costs anyway (54 joint options for Tool Delivery).
``masked_fill`` stops gradients at the masked entries, so only logits inside the slice learn.

Every ``-inf`` here is guarded so that forward *and* backward stay NaN-free: a choosing agent must
have at least one available option (checked), entropies use ``0·(−inf) = 0``, and marginals never
take a ``logsumexp`` over an all-``−inf`` lane.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Protocol, runtime_checkable

import torch
from torch import Tensor

from maopg.policy.choices import EXPLORE_FORMS


class JointOptionDistribution(Protocol):
    """What a policy hands to a learner for one batch of decision points.

    Joint options are ``int64 [B, N]``; entries of non-choosing agents equal ``running``.
    ``log_prob`` and ``entropy`` count only the choosing agents' decision (the continuing
    agents' options have probability 1 given the condition).
    """

    def sample(self, generator: torch.Generator | None = None) -> Tensor: ...

    def log_prob(self, joint: Tensor) -> Tensor: ...

    def entropy(self) -> Tensor: ...

    def mode(self) -> Tensor: ...


@runtime_checkable
class ChainRuleDistribution(JointOptionDistribution, Protocol):
    """A joint distribution that factors by the chain rule over the agents in the spec's order,
    ``π(o^U) = Π_{i∈U} π(o^i | o^{<i}, c, z)``, and exposes its factors: what exploration by
    mixing (:class:`EpsilonMixture`) acts on. Every built-in policy's conditional is one."""

    choosing: Tensor
    running: Tensor

    def decode(self, pick: Callable[[Tensor], Tensor]) -> Tensor:
        """The joint ``int64 [B, N]`` drawn agent after agent: each choosing agent's option is
        ``pick(log π(· | o^{<i}, c, z))`` (``[B, max K]`` → ``[B]``; ``−inf`` where the agent may
        not go), continuing agents keep their running option."""
        ...

    def factor_log_probs(self, joint: Tensor) -> Tensor:
        """``[B, N, max K]``: each agent's factor ``log π(· | o^{<i}, c, z)`` along ``joint``
        (a continuing agent's is the one-hot of its running option; padding is ``−inf``)."""
        ...


def split_available(available: Tensor, option_counts: Sequence[int]) -> list[Tensor]:
    """Split ``bool [B, ΣK_i]`` availability into per-agent ``bool [B, K_i]`` masks."""
    if available.shape[-1] != sum(option_counts):
        raise ValueError(
            f"available has {available.shape[-1]} columns, option counts sum to "
            f"{sum(option_counts)}"
        )
    return list(torch.split(available.bool(), list(option_counts), dim=-1))


def agent_masks(
    choosing: Tensor, running: Tensor, available: Tensor, option_counts: Sequence[int]
) -> list[Tensor]:
    """Per-agent ``bool [B, K_i]`` masks of the options each agent may take in the slice.

    A choosing agent may take its available options; a continuing agent only its running
    option (its availability mask is ignored: the option is already executing).
    Raises ``ValueError`` if some row leaves an agent with nothing, which would make the
    conditional undefined (a choosing agent with no available option, or a continuing agent
    whose running option is out of range, e.g. ``-1``).
    """
    n = len(option_counts)
    if choosing.shape[-1] != n or running.shape[-1] != n:
        raise ValueError(
            f"{n} agents in the joint, but choosing/running have {choosing.shape[-1]}/"
            f"{running.shape[-1]} columns"
        )
    choosing = choosing.bool()
    masks = []
    for i, (avail, k) in enumerate(
        zip(split_available(available, option_counts), option_counts, strict=True)
    ):
        options = torch.arange(k, device=running.device)
        is_running = options == running[:, i : i + 1]
        masks.append(torch.where(choosing[:, i : i + 1], avail, is_running))
    empty = ~torch.stack([m.any(dim=-1) for m in masks], dim=-1)
    if bool(empty.any()):
        row, agent = (int(v) for v in empty.nonzero()[0])
        raise ValueError(
            f"row {row}: agent {agent} has no admissible option (choosing="
            f"{bool(choosing[row, agent])}, running={int(running[row, agent])})"
        )
    return masks


def _outer_and(masks: Sequence[Tensor]) -> Tensor:
    """``bool [B, K_0, ..., K_{N-1}]`` with entry ``o`` true iff ``masks[i][o_i]`` for all i."""
    n = len(masks)
    joint = masks[0].view(masks[0].shape[0], -1, *([1] * (n - 1)))
    for i in range(1, n):
        shape = [masks[i].shape[0]] + [1] * i + [masks[i].shape[1]] + [1] * (n - 1 - i)
        joint = joint & masks[i].view(shape)
    return joint


def joint_slice_mask(
    choosing: Tensor, running: Tensor, available: Tensor, option_counts: Sequence[int]
) -> Tensor:
    """``bool [B, K_0, ..., K_{N-1}]``: the joint options the conditional may put mass on.

    Also what a value-based learner (Mac-DQN) needs for its conditional argmax over joint Q.
    """
    return _outer_and(agent_masks(choosing, running, available, option_counts))


def _strides(option_counts: Sequence[int], device: torch.device) -> Tensor:
    """``int64 [N]``: how far one step of agent i's option moves in the row-major joint."""
    strides = [math.prod(option_counts[i + 1 :]) for i in range(len(option_counts))]
    return torch.tensor(strides, device=device)


def ravel_joint(joint: Tensor, option_counts: Sequence[int]) -> Tensor:
    """``int64 [B, N]`` joint options to flat indices ``[B]`` into the row-major joint."""
    return (joint * _strides(option_counts, joint.device)).sum(dim=-1)


def unravel_joint(flat: Tensor, option_counts: Sequence[int]) -> Tensor:
    """Flat indices ``[B]`` back to ``int64 [B, N]`` joint options.

    The integer arithmetic of ``torch.unravel_index``, written out: its argument checks
    (``torch._check_type``) import ``torch.fx``'s symbolic shapes and sympy at the first call,
    ~0.3 s of every training process's start-up for the first option drawn.
    """
    counts = torch.tensor(tuple(option_counts), device=flat.device)
    return (
        flat.unsqueeze(-1).div(_strides(option_counts, flat.device), rounding_mode="floor") % counts
    )


def conditional_log_probs(
    joint_logits: Tensor, choosing: Tensor, running: Tensor, available: Tensor
) -> Tensor:
    """``log π̂`` over the flattened joint, ``[B, ΠK_i]``: −inf outside the slice.

    ``joint_logits`` is ``[B, K_0, ..., K_{N-1}]``; the option counts are read from its shape.
    """
    counts = tuple(joint_logits.shape[1:])
    mask = joint_slice_mask(choosing, running, available, counts)
    flat = joint_logits.reshape(joint_logits.shape[0], -1)
    return torch.log_softmax(flat.masked_fill(~mask.reshape(flat.shape), -math.inf), dim=-1)


def partial_conditional_log_probs(
    agent_joint_logits: Sequence[Tensor], choosing: Tensor, running: Tensor, available: Tensor
) -> list[Tensor]:
    """Per-agent ``log π̂^i(o^i | c, z^i)``, ``[B, K_i]``, of the partially centralized policy.

    ``agent_joint_logits[i]`` is agent i's own joint logits ``[B, K_0, ..., K_{N-1}]`` (from its
    local observation). Agent i conditions them on the slice (continuing agents fixed at ``c``,
    unavailable options removed), marginalises the *other* choosing agents out (logsumexp) and
    renormalises over its own options. A continuing agent's result is the one-hot of its running
    option (log-prob 0), i.e. probability 1 (paper Eq. 5).
    """
    counts = tuple(agent_joint_logits[0].shape[1:])
    if len(agent_joint_logits) != len(counts):
        raise ValueError(f"need one joint-logit tensor per agent ({len(counts)})")
    masks = agent_masks(choosing, running, available, counts)
    slice_mask = _outer_and(masks)
    n = len(counts)
    result = []
    for i, logits in enumerate(agent_joint_logits):
        masked = logits.masked_fill(~slice_mask, -math.inf)
        # A lane o_i that agent i may not take holds only -inf, and logsumexp's backward over it
        # is exp(-inf - -inf) = NaN (zeroed again only by the masked_fill's backward). Fill such
        # lanes with a finite 0 and mask their marginal below, so no NaN exists at any stage.
        lane_shape = [masks[i].shape[0]] + [1] * i + [counts[i]] + [1] * (n - 1 - i)
        masked = torch.where(masks[i].view(lane_shape), masked, 0.0)
        others = tuple(d + 1 for d in range(n) if d != i)
        marginal = torch.logsumexp(masked, dim=others) if others else masked
        result.append(torch.log_softmax(marginal.masked_fill(~masks[i], -math.inf), dim=-1))
    return result


def draw_multinomial(weights: Tensor, generator: torch.Generator | None = None) -> Tensor:
    """One index per row of ``weights`` ``[B, K]`` (``torch.multinomial``), ``[B]`` on the
    weights' device, drawn on the *generator's* device.

    A CPU generator cannot drive a draw on CUDA tensors, and the learners' generators are CPU
    generators (checkpointed, seeded from the run's seed): so the weights come to the
    generator, not the other way round. On a CPU run both moves are no-ops and the draws are
    exactly those of ``torch.multinomial(weights, 1, generator=generator)``; on CUDA the
    weights cross to the host once per decision, which acting pays anyway (the joint option
    goes to the environments as numpy).
    """
    device = weights.device if generator is None else generator.device
    picks = torch.multinomial(weights.to(device), 1, generator=generator).squeeze(-1)
    return picks.to(weights.device)


def _padded(log_probs: Sequence[Tensor]) -> Tensor:
    """Per-agent ``[B, K_i]`` log-probabilities stacked as ``[B, N, max K]``, padded with −inf."""
    width = max(lp.shape[-1] for lp in log_probs)
    pad = torch.nn.functional.pad
    return torch.stack([pad(lp, (0, width - lp.shape[-1]), value=-math.inf) for lp in log_probs], 1)


def _categorical_entropy(log_probs: Tensor) -> Tensor:
    """Entropy over the last dim, with ``0·log 0 = 0`` in forward and backward."""
    finite = torch.isfinite(log_probs)
    return -(log_probs.exp() * log_probs.masked_fill(~finite, 0.0)).sum(dim=-1)


class ConditionalJoint:
    """The fully centralized conditional ``π̂(o^U | c, z)`` for a batch (product categorical)."""

    def __init__(
        self, joint_logits: Tensor, choosing: Tensor, running: Tensor, available: Tensor
    ) -> None:
        self.option_counts = tuple(joint_logits.shape[1:])
        self.choosing = choosing.bool()
        self.running = running
        self.log_probs = conditional_log_probs(joint_logits, choosing, running, available)
        """``[B, ΠK_i]`` log-probabilities over the flattened joint (−inf outside the slice)."""
        self._available = available

    @property
    def probs(self) -> Tensor:
        return self.log_probs.exp()

    def sample(self, generator: torch.Generator | None = None) -> Tensor:
        return unravel_joint(draw_multinomial(self.probs, generator), self.option_counts)

    def log_prob(self, joint: Tensor) -> Tensor:
        """``log π̂`` of ``int64 [B, N]`` joint options; non-choosing entries are ignored."""
        joint = torch.where(self.choosing, joint, self.running)
        flat = ravel_joint(joint, self.option_counts)
        return self.log_probs.gather(-1, flat.unsqueeze(-1)).squeeze(-1)

    def entropy(self) -> Tensor:
        return _categorical_entropy(self.log_probs)

    def mode(self) -> Tensor:
        return unravel_joint(self.log_probs.argmax(dim=-1), self.option_counts)

    # ------------------------------------------------------------------ the chain rule
    def decode(self, pick: Callable[[Tensor], Tensor]) -> Tensor:
        return self._chain(lambda _, factor: pick(factor))[0]

    def factor_log_probs(self, joint: Tensor) -> Tensor:
        joint = torch.where(self.choosing, joint, self.running)
        return self._chain(lambda i, _: joint[:, i])[1]

    def _chain(self, pick: Callable[[int, Tensor], Tensor]) -> tuple[Tensor, Tensor]:
        """The joint and its factors ``[B, N, max K]``, agent after agent: agent i's factor is
        the slice's marginal over the later agents at the earlier agents' picks, renormalised
        over agent i's admissible options. A lane agent i may not take holds only −inf, and a
        ``logsumexp`` over it has a NaN gradient: such lanes are summed over zeros and masked
        after (as :func:`partial_conditional_log_probs` does)."""
        counts = self.option_counts
        masks = agent_masks(self.choosing, self.running, self._available, counts)
        table = self.log_probs.view(-1, *counts)
        joint = self.running.clone()
        factors = []
        for i, mask in enumerate(masks):
            lanes = mask.view(*mask.shape, *([1] * (table.dim() - 2)))
            later = tuple(range(2, table.dim()))
            summed = torch.where(lanes, table, 0.0)
            marginal = torch.logsumexp(summed, dim=later) if later else summed
            factor = torch.log_softmax(marginal.masked_fill(~mask, -math.inf), dim=-1)
            rows = self.choosing[:, i]
            if bool(rows.any()):
                joint[:, i] = torch.where(rows, pick(i, factor), joint[:, i])
            factors.append(factor)
            index = joint[:, i].clone().view(-1, 1, *([1] * (table.dim() - 2)))
            table = table.gather(1, index.expand(-1, 1, *table.shape[2:])).squeeze(1)
        return joint, _padded(factors)


class FactoredConditional:
    """Independent per-agent conditionals (the partially centralized policy, paper Eq. 5).

    Each choosing agent samples from its own ``π̂^i``; the joint log-prob is the sum over the
    choosing agents, and so is the entropy. Continuing agents contribute nothing.
    """

    def __init__(self, agent_log_probs: Sequence[Tensor], choosing: Tensor, running: Tensor):
        self.agent_log_probs = list(agent_log_probs)
        """Per-agent ``[B, K_i]`` log-probabilities (one-hot of ``running`` for continuing)."""
        self.choosing = choosing.bool()
        self.running = running

    def sample(self, generator: torch.Generator | None = None) -> Tensor:
        picks = [draw_multinomial(lp.exp(), generator) for lp in self.agent_log_probs]
        return torch.where(self.choosing, torch.stack(picks, dim=-1), self.running)

    def log_prob(self, joint: Tensor) -> Tensor:
        """Sum over choosing agents of ``log π̂^i(o^i)``; non-choosing entries are ignored."""
        joint = torch.where(self.choosing, joint, self.running)
        per_agent = torch.stack(
            [
                lp.gather(-1, joint[:, i : i + 1]).squeeze(-1)
                for i, lp in enumerate(self.agent_log_probs)
            ],
            dim=-1,
        )
        return per_agent.masked_fill(~self.choosing, 0.0).sum(dim=-1)

    def entropy(self) -> Tensor:
        per_agent = torch.stack([_categorical_entropy(lp) for lp in self.agent_log_probs], dim=-1)
        return per_agent.masked_fill(~self.choosing, 0.0).sum(dim=-1)

    def mode(self) -> Tensor:
        picks = torch.stack([lp.argmax(dim=-1) for lp in self.agent_log_probs], dim=-1)
        return torch.where(self.choosing, picks, self.running)

    def decode(self, pick: Callable[[Tensor], Tensor]) -> Tensor:
        """Each agent's pick from its own conditional: the factors do not depend on each other."""
        picks = torch.stack([pick(lp) for lp in self.agent_log_probs], dim=-1)
        return torch.where(self.choosing, picks, self.running)

    def factor_log_probs(self, joint: Tensor) -> Tensor:
        return _padded(self.agent_log_probs)


# ---------------------------------------------------------------------------- exploration
def mix_uniform(log_probs: Tensor, epsilon: Tensor) -> Tensor:
    """``log((1 − ε)·p + ε·u)`` over the last dim, ``u`` uniform over the entries ``p`` allows
    (the finite ones); ``epsilon`` is ``[B]`` for the leading dim. Entries ``p`` rules out stay
    −inf, so the mixture never selects an unavailable option. NaN-free in forward and backward
    at ε = 0 and ε = 1 (every ``logaddexp`` has a finite side where it is taken)."""
    allowed = torch.isfinite(log_probs)
    count = allowed.sum(dim=-1, keepdim=True).clamp(min=1)
    eps = epsilon.to(log_probs.dtype).view(-1, *([1] * (log_probs.dim() - 1)))
    keep = torch.log1p(-eps) + torch.where(allowed, log_probs, 0.0)
    mixed = torch.logaddexp(keep, torch.log(eps) - count.log())
    return mixed.masked_fill(~allowed, -math.inf)


class EpsilonMixture:
    """The behaviour policy of ε-mixed exploration: each *choosing* agent's chain-rule factor
    ``π(o^i | o^{<i}, c, z)`` mixed with the uniform distribution over that agent's available
    options, ``μ_i = (1 − ε)·π_i + ε/|A_i|``; continuing agents keep their running option.

    Why per agent and along the chain rule: this is the per-agent mixture of the literature's
    decentralized actors (ACAC samples ``(1 − ε)·π + ε/K`` per agent, reference §10) written for
    the conditional centralized policy; an agent that explores is followed by later agents'
    conditionals given its choice (a partner can learn to join an explored move), and at ε = 1
    it is the uniform policy over the slice whatever the network says. ``log_prob`` is
    ``Σ_{i∈U} log μ_i``, which PPO uses in its ratio for the acting and the updated policy
    alike (as ACAC does), so the update stays on-policy for the behaviour that collected the
    batch. ``entropy`` and ``mode`` are the policy's own: the entropy bonus regularises π, not
    the mixture, and evaluation never explores.
    """

    def __init__(self, base: ChainRuleDistribution, epsilon: Tensor) -> None:
        self.base = base
        self.epsilon = epsilon
        """``float [B]``: the mixing weight of each row."""
        self.choosing = base.choosing

    def sample(self, generator: torch.Generator | None = None) -> Tensor:
        return self.base.decode(
            lambda lp: draw_multinomial(mix_uniform(lp, self.epsilon).exp(), generator)
        )

    def log_prob(self, joint: Tensor) -> Tensor:
        """``Σ`` over the choosing agents of ``log μ_i(o^i | o^{<i})`` along ``joint``."""
        joint = torch.where(self.choosing, joint, self.base.running)
        mixed = mix_uniform(self.base.factor_log_probs(joint), self.epsilon)
        picked = mixed.gather(-1, joint.unsqueeze(-1)).squeeze(-1)
        return picked.masked_fill(~self.choosing, 0.0).sum(dim=-1)

    def entropy(self) -> Tensor:
        return self.base.entropy()

    def mode(self) -> Tensor:
        return self.base.mode()


class JointMixture:
    """The behaviour policy of ε-mixed exploration over the *joint* option:
    ``μ(o^U) = (1 − ε)·π(o^U | c, z) + ε·Π_{i∈U} 1/|A_i|`` — with probability ε every choosing
    agent draws uniformly from its available options, else the policy draws the joint.

    Why a joint form beside :class:`EpsilonMixture`: scored through per-agent factors, a sample
    where one agent took an option that fails unless its partner takes the matching one (Box
    Pushing's lone push at the big box) lowers the *marginal* of that option, and so every
    joint option containing it — the coordinated one too (the relative overgeneralisation of
    independent learners). Scored as a joint, ``log μ(o)`` depends on the policy only through
    ``π(o)``: for the product categorical (``async``) a failed lone push lowers that joint
    option alone, which is what a centralized policy is for (a factored or autoregressive
    policy's ``π(o)`` is still a product of per-agent factors). At ε = 1 both forms are the same
    uniform policy over the slice.
    """

    def __init__(
        self, base: JointOptionDistribution, epsilon: Tensor, masks: Sequence[Tensor]
    ) -> None:
        self.base = base
        self.epsilon = epsilon
        self.masks = list(masks)
        """Per-agent ``bool [B, K_i]``: what each agent may take (its running option alone when
        it continues), as :func:`agent_masks` gives them."""
        self.choosing = base.choosing  # type: ignore[attr-defined]
        self.running = base.running  # type: ignore[attr-defined]
        sizes = torch.stack([m.sum(dim=-1) for m in self.masks], dim=-1).float()
        self._log_uniform = -torch.where(self.choosing, sizes.log(), 0.0).sum(dim=-1)

    def sample(self, generator: torch.Generator | None = None) -> Tensor:
        policy = self.base.sample(generator)
        device = self.epsilon.device if generator is None else generator.device
        explores = torch.rand(self.epsilon.shape, generator=generator, device=device)
        uniform = torch.stack([draw_multinomial(m.float(), generator) for m in self.masks], -1)
        uniform = torch.where(self.choosing, uniform, self.running)
        explored = explores.to(self.epsilon.device) < self.epsilon
        return torch.where(explored[:, None], uniform, policy)

    def log_prob(self, joint: Tensor) -> Tensor:
        """``log μ`` of ``int64 [B, N]`` joints: −inf outside the slice (an unavailable option
        of a choosing agent, or another option than its running one for a continuing agent)."""
        joint = torch.where(self.choosing, joint, self.running)
        inside = torch.stack(
            [m.gather(-1, joint[:, i : i + 1]).squeeze(-1) for i, m in enumerate(self.masks)], -1
        ).all(dim=-1)
        eps = self.epsilon.to(self._log_uniform.dtype)
        policy = torch.log1p(-eps) + self.base.log_prob(joint)
        uniform = torch.where(inside, torch.log(eps) + self._log_uniform, -math.inf)
        return torch.logaddexp(policy, uniform)

    def entropy(self) -> Tensor:
        return self.base.entropy()

    def mode(self) -> Tensor:
        return self.base.mode()


def explore(
    dist: JointOptionDistribution,
    epsilon: float | Tensor,
    form: str = "agent",
    conditions: tuple[Tensor, Tensor, Tensor] | None = None,
    option_counts: Sequence[int] = (),
) -> JointOptionDistribution:
    """``dist`` mixed with uniform exploration of weight ``epsilon`` (a number, or ``[B]`` one
    per row), per agent (``form="agent"``: :class:`EpsilonMixture`) or over the joint
    (``"joint"``: :class:`JointMixture`, which needs the decision points' ``conditions``,
    ``(choosing, running, available)``, and the agents' ``option_counts``), or ``dist`` itself
    where ε is 0 in every row: a run without exploration draws and scores exactly as it did
    before the mechanism existed."""
    if form not in EXPLORE_FORMS:
        raise ValueError(f"exploration form must be one of {list(EXPLORE_FORMS)}, got {form!r}")
    if not bool(torch.as_tensor(epsilon).any()):
        return dist
    if form == "joint":
        if conditions is None:
            raise ValueError("joint exploration needs the decision points' conditions")
        choosing, running, available = conditions
        rows = choosing.shape[0]
        if not isinstance(epsilon, Tensor):
            epsilon = torch.full((rows,), float(epsilon), device=choosing.device)
        masks = agent_masks(choosing, running, available, option_counts)
        return JointMixture(dist, epsilon, masks)
    if not isinstance(dist, ChainRuleDistribution):
        raise TypeError(
            f"exploration by mixing (ppo.explore_eps) needs a policy whose conditional factors "
            f"by agent (decode, factor_log_probs: ChainRuleDistribution); "
            f"{type(dist).__name__} does not"
        )
    if not isinstance(epsilon, Tensor):
        epsilon = torch.full(dist.choosing.shape[:1], float(epsilon), device=dist.choosing.device)
    return EpsilonMixture(dist, epsilon)


# ---------------------------------------------------------------------------- joint Q-values
def conditional_argmax(
    q: Tensor,
    choosing: Tensor,
    running: Tensor,
    available: Tensor,
    option_counts: Sequence[int],
) -> Tensor:
    """Flat index ``[B]`` of the best joint option in each row's conditional slice.

    Continuing agents keep ``running``; choosing agents range over their available options.
    """
    mask = joint_slice_mask(choosing, running, available, option_counts).reshape(q.shape)
    return q.masked_fill(~mask, -math.inf).argmax(dim=-1)


def epsilon_greedy(
    q: Tensor,
    choosing: Tensor,
    running: Tensor,
    available: Tensor,
    option_counts: Sequence[int],
    epsilon: float,
    generator: torch.Generator,
) -> Tensor:
    """Joint options ``int64 [B, N]``: the conditional argmax, then each *choosing* agent
    independently (as MacDeepMARL) switches with probability ε to a uniform available option.
    Continuing agents always keep their running option."""
    joint = unravel_joint(
        conditional_argmax(q, choosing, running, available, option_counts), option_counts
    )
    choosing = choosing.bool()
    masks = torch.split(available.bool(), list(option_counts), dim=-1)
    # Drawn on the generator's device, like draw_multinomial (a no-op move on the CPU).
    uniform = torch.rand(choosing.shape, generator=generator, device=generator.device)
    explore = uniform.to(choosing.device) < epsilon
    for i, mask in enumerate(masks):
        # Rows whose agent i is not choosing may have an all-false mask: give multinomial
        # something valid there; the pick is discarded by the where below.
        weights = torch.where(choosing[:, i : i + 1], mask, True).float()
        random = draw_multinomial(weights, generator)
        joint[:, i] = torch.where(explore[:, i] & choosing[:, i], random, joint[:, i])
    return torch.where(choosing, joint, running)

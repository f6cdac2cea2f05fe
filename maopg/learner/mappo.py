"""The MAPPO update on option-level batches (docs/DESIGN.md §5; Yu et al. 2021's defaults).

Actor and critic are separate networks with separate Adam optimisers and separate gradient-norm
clipping, as in MAPPO. The actor's objective is PPO's clipped surrogate on the ratio of
*conditional* probabilities ``π̂(o^U | c, z)``: agents that were continuing at a decision point have
probability 1 given the condition and so contribute nothing to the ratio or the entropy — that is
the paper's conditional policy gradient. The critic regresses normalised value targets with a
Huber loss, clipped around the old prediction like the policy ratio.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor, nn

from maopg.learner.buffer import TrainBatch
from maopg.learner.value_norm import ValueNorm
from maopg.policy import CentralCritic, OptionPolicy


@dataclass(frozen=True)
class PPOConfig:
    """Hyper-parameters of one PPO update (defaults: MAPPO reference, docs/DESIGN.md §5)."""

    epochs: int = 10
    num_minibatches: int = 1
    clip: float = 0.2
    value_clip: float = 0.2
    huber_delta: float = 10.0
    ent_coef: float = 0.01
    value_coef: float = 1.0
    lr: float = 5e-4
    critic_lr: float = 5e-4
    adam_eps: float = 1e-5
    max_grad_norm: float = 10.0
    normalize_advantages: bool = True


@dataclass
class Losses:
    """Per-minibatch loss terms (tensors, differentiable where it matters)."""

    policy: Tensor
    value: Tensor
    entropy: Tensor
    approx_kl: Tensor
    clip_fraction: Tensor


class MAPPO:
    """Clipped-surrogate updates of a conditional option policy and a centralized critic."""

    def __init__(
        self,
        policy: OptionPolicy,
        critic: CentralCritic,
        value_norm: ValueNorm | None,
        config: PPOConfig,
    ) -> None:
        self.policy = policy
        self.critic = critic
        self.value_norm = value_norm
        self.config = config
        self.policy_opt = torch.optim.Adam(policy.parameters(), lr=config.lr, eps=config.adam_eps)
        self.critic_opt = torch.optim.Adam(
            critic.parameters(), lr=config.critic_lr, eps=config.adam_eps
        )

    def value_targets(self, returns: Tensor) -> Tensor:
        """Returns in the critic's space (normalised when value normalisation is on)."""
        return returns if self.value_norm is None else self.value_norm.normalize(returns)

    def losses(self, batch: TrainBatch, advantages: Tensor, targets: Tensor) -> Losses:
        """PPO losses of ``batch`` given its (normalised) advantages and critic-space targets."""
        cfg = self.config
        dist = self.policy.distribution(batch.obs, batch.choosing, batch.running, batch.available)
        log_prob = dist.log_prob(batch.joint)
        log_ratio = log_prob - batch.old_log_prob
        ratio = log_ratio.exp()
        surrogate = torch.min(
            ratio * advantages, ratio.clamp(1.0 - cfg.clip, 1.0 + cfg.clip) * advantages
        )
        values = self.critic(batch.obs)
        clipped = batch.old_value + (values - batch.old_value).clamp(
            -cfg.value_clip, cfg.value_clip
        )
        huber = nn.functional.huber_loss
        value_loss = torch.max(
            huber(values, targets, reduction="none", delta=cfg.huber_delta),
            huber(clipped, targets, reduction="none", delta=cfg.huber_delta),
        )
        with torch.no_grad():
            approx_kl = ((ratio - 1.0) - log_ratio).mean()
            clip_fraction = ((ratio - 1.0).abs() > cfg.clip).float().mean()
        return Losses(
            policy=-surrogate.mean(),
            value=value_loss.mean(),
            entropy=dist.entropy().mean(),
            approx_kl=approx_kl,
            clip_fraction=clip_fraction,
        )

    def update(self, batch: TrainBatch, generator: torch.Generator) -> dict[str, float]:
        """Run ``epochs`` passes of ``num_minibatches`` shuffled minibatches over ``batch``.

        Updates the value normaliser with the batch's returns first (MAPPO), so the critic's
        targets are normalised with statistics that include them. Returns mean statistics.
        """
        cfg = self.config
        if self.value_norm is not None:
            self.value_norm.update(batch.returns)
        targets = self.value_targets(batch.returns)
        advantages = batch.advantages
        if cfg.normalize_advantages and len(batch) > 1:
            advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-5)

        sums = dict.fromkeys(
            ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction"), 0.0
        )
        updates = 0
        size = len(batch)
        num_minibatches = max(1, min(cfg.num_minibatches, size))
        for _ in range(cfg.epochs):
            order = torch.randperm(size, generator=generator)
            for index in order.tensor_split(num_minibatches):
                losses = self.losses(batch.rows(index), advantages[index], targets[index])
                self.policy_opt.zero_grad()
                (losses.policy - cfg.ent_coef * losses.entropy).backward()
                nn.utils.clip_grad_norm_(self.policy.parameters(), cfg.max_grad_norm)
                self.policy_opt.step()
                self.critic_opt.zero_grad()
                (cfg.value_coef * losses.value).backward()
                nn.utils.clip_grad_norm_(self.critic.parameters(), cfg.max_grad_norm)
                self.critic_opt.step()

                sums["policy_loss"] += losses.policy.item()
                sums["value_loss"] += losses.value.item()
                sums["entropy"] += losses.entropy.item()
                sums["approx_kl"] += losses.approx_kl.item()
                sums["clip_fraction"] += losses.clip_fraction.item()
                updates += 1
        return {key: total / updates for key, total in sums.items()}

    def state_dict(self) -> dict[str, dict]:
        return {
            "policy_opt": self.policy_opt.state_dict(),
            "critic_opt": self.critic_opt.state_dict(),
        }

    def load_state_dict(self, state: dict[str, dict]) -> None:
        self.policy_opt.load_state_dict(state["policy_opt"])
        self.critic_opt.load_state_dict(state["critic_opt"])

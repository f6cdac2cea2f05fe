"""ACAC, Agent-Centric Actor-Critic (Jung et al., ICML 2025), on this project's layers.

Networks: :mod:`maopg.policy.agent_centric` (one recurrent actor per agent and an attention
critic over the agents' own histories, each advancing only at its agent's decisions). One
iteration is one of ACAC's collection rounds followed by its update, top to bottom in
:meth:`ACACLearner.iteration`:

1. **Collect** (:meth:`ACACLearner.collect`): every environment starts a new episode and all step
   in lockstep until the tick by which at least ``episodes_per_update`` episodes have finished
   in this round (an environment whose episode ends starts the next at once); the batch is the
   last ``episodes_per_update`` of them to finish, and the unfinished episodes are dropped.
   Choosing agents draw from ``(1 − ε) π_i + ε · uniform`` over their available options, ε
   falling linearly in the episode counter, which grows by ``episodes_per_update`` a round.
2. **Advantages** over each episode's decision points (every point where some agent chooses):
   the *target* critic's values, the ``event`` form of GAE (:mod:`maopg.learner.gae`: the trace
   decays by ``γ^k λ`` per decision), bootstrapping a timeout from the final point's value and
   a terminal state from 0. One advantage per decision point, shared by the agents that chose
   there; each agent's loss reads it at its own decisions.
3. **Update**, ``train_repeat`` times on the whole batch: one critic step (mean squared error to
   the PopArt-normalised returns; PopArt's statistics updated with the batch's returns first),
   then one step of each actor on PPO's clipped surrogate (clip ``clip``) of its own ε-mixed
   probabilities, old and new (the old recomputed from the collecting weights), averaged over
   its own decisions. No entropy bonus, no gradient clipping; Adam per network.
4. The target critic is copied from the critic every ``target_every`` episodes of the counter.

Counters: ``samples`` (maopg's, what the trainer counts) are every tick simulated, discarded
episodes included; ``published_steps`` is the one ACAC's logs plot, the summed length of the
training episodes that finished. ``gamma`` is the run's (ACAC's runs: 0.98) and the number of
environments the run's ``num_envs`` (ACAC's: 32); ``batch_ticks`` does not apply.

Choices where the paper is silent, or where the authors' code differs from its description:
values are denormalised with the statistics of the network that computed them (the code reads
the target critic's outputs with the online critic's, up to four rounds newer). Two more of the
code's departures are settings, the description's form by default: the return at an episode's
last decision is ``A + V`` as everywhere (``acac.last_target=advantage``: ``A`` alone, as the
code computes it), and every decision of an agent is trained on, including one whose option the
episode's end cut short (``acac.cut_decisions=drop``: left out, as the code does).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import torch
from torch import Tensor

from maopg.env.contract import EnvSpec
from maopg.learner.base import (
    LearnerSetup,
)
from maopg.learner.gae import DiscountForm, compute_gae
from maopg.learner.rounds import Episodes, RoundsLearner
from maopg.learner.sections import ACACConfig
from maopg.policy.agent_centric import AgentCentricCritic, AgentCentricPolicy, scan
from maopg.policy.joint_size import BuildTarget


class ACACLearner(RoundsLearner):
    """ACAC's rounds and updates (module docstring)."""

    Config = ACACConfig
    section = "acac"
    columns: ClassVar[tuple[str, ...]] = (
        "policy_loss",
        "value_loss",
        "entropy",
        "approx_kl",
        "epsilon",
        "published_steps",
    )
    """``entropy``: the policy's own (unmixed), summed over the choosing agents of a decision
    point; ``published_steps``: ACAC's own counter, the summed length of the finished training
    episodes so far (what its published curves are plotted against)."""

    def __init__(self, policy: AgentCentricPolicy, setup: LearnerSetup) -> None:
        cfg: ACACConfig = setup.config
        critic = AgentCentricCritic(
            setup.spec, width=cfg.width, heads=cfg.heads, popart_beta=cfg.popart_beta
        )
        super().__init__(policy, setup, critic)

    def _values(self, critic: AgentCentricCritic, batch: Episodes) -> Tensor:
        """``critic``'s normalised values ``[T, B]`` along the batch's points."""
        obs = batch.obs.to(self.device)
        steps = batch.choosing.shape[:2]
        states = scan(
            critic.cells,
            [net(obs) for net in critic.inputs],
            batch.choosing.to(self.device),
            batch.starts.to(self.device),
            critic.initial_state(steps[1]).to(self.device),
        )
        return critic.value(states.flatten(0, 1)).view(steps)

    def advantages(self, batch: Episodes) -> tuple[np.ndarray, np.ndarray]:
        """``[T, B]`` advantages and returns from the target critic's values (module
        docstring), in return units."""
        with torch.no_grad():
            values = self.target.value_head.denormalize(self._values(self.target, batch))
        values = values.cpu().double().numpy()
        steps = batch.steps.numpy()
        last = np.zeros_like(steps)
        last[batch.length - 1, np.arange(len(batch.length))] = True
        terminal = last & batch.terminated[None, :]
        next_values = np.concatenate([values[1:], np.zeros_like(values[:1])])
        advantages, returns = compute_gae(
            values=np.where(steps, values, 0.0),
            next_values=np.where(steps, next_values, 0.0),
            reward_sum=np.where(steps, batch.reward_sum, 0.0),
            reward_discounted=np.where(steps, batch.reward, 0.0),
            durations=batch.duration,
            terminated=terminal,
            continues=steps & ~last,
            gamma=self.setup.gamma,
            lam=self.config.gae_lambda,
            form=DiscountForm.EVENT,
        )
        if self.config.last_target == "advantage":
            returns = np.where(last, advantages, returns)
        return advantages, returns

    def update(self, batch: Episodes, epsilon: float) -> dict[str, float]:
        """``train_repeat`` full-batch steps of the critic, then of each actor."""
        cfg: ACACConfig = self.config
        advantages, returns = self.advantages(batch)
        steps = batch.steps.to(self.device)
        head = self.critic.value_head
        returns_t = torch.as_tensor(returns, dtype=torch.float32, device=self.device)
        head.update(returns_t[steps])
        targets = head.normalize(returns_t)
        advantage = torch.as_tensor(advantages, dtype=torch.float32, device=self.device)
        with torch.no_grad():
            old, _ = self.agent_log_probs(batch, epsilon)
        deciding = batch.deciding
        if cfg.cut_decisions == "drop":
            deciding &= ~cut_short(batch)
        deciding = deciding.to(self.device)
        sums = dict.fromkeys(("policy_loss", "value_loss", "entropy", "approx_kl"), 0.0)
        for _ in range(cfg.train_repeat):
            value_loss = (self._values(self.critic, batch) - targets)[steps].square().mean()
            self.step_critic(value_loss)
            sums["value_loss"] += value_loss.item()
            new, entropy = self.agent_log_probs(batch, epsilon)
            sums["entropy"] += entropy[steps].mean().item()
            losses, log_ratios = {}, []
            for i in range(len(self.actor_opts)):
                mine = deciding[..., i]
                if not bool(mine.any()):
                    continue
                log_ratio = (new[i] - old[i])[mine]
                ratio = log_ratio.exp()
                a = advantage[mine]
                surrogate = torch.min(ratio * a, ratio.clamp(1 - cfg.clip, 1 + cfg.clip) * a)
                losses[i] = -surrogate.mean()
                log_ratios.append(log_ratio.detach())
            self.step_actors(losses)
            sums["policy_loss"] += float(np.mean([loss.item() for loss in losses.values()]))
            kl = torch.cat([(r.exp() - 1) - r for r in log_ratios]).mean()
            sums["approx_kl"] += kl.item()
        self.require_finite_networks()
        return {key: total / cfg.train_repeat for key, total in sums.items()}


def cut_short(batch: Episodes) -> Tensor:
    """``bool [T, B, N]``: each agent's last decision of each episode whose option had not ended
    when the episode did (the final point's ``choosing`` marks the options that ended there)."""
    steps, episodes, agents = batch.choosing.shape
    index = torch.arange(episodes)
    deciding = batch.deciding
    last = (deciding.long() * torch.arange(steps).view(-1, 1, 1)).argmax(0)
    ended = batch.choosing[torch.from_numpy(batch.length), index]
    cut = torch.zeros_like(deciding)
    cut[last, index.unsqueeze(1), torch.arange(agents)] = deciding.any(0) & ~ended
    return cut


def agent_centric_policy(
    spec: EnvSpec, *, hidden: int, layers: int, config: ACACConfig, target: BuildTarget
) -> AgentCentricPolicy:
    """ACAC's actors at ``acac.width`` (the run's ``hidden``/``layers`` size maopg's own
    networks; ACAC's are the published 32-wide ones)."""
    del hidden, layers, target
    return AgentCentricPolicy(spec, width=config.width)

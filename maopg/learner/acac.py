"""ACAC, Agent-Centric Actor-Critic (Xiao et al., ICML 2025), on this project's layers.

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
the target critic's outputs with the online critic's, up to four rounds newer); the return at
an episode's last decision is ``A + V`` as everywhere (the code drops the ``V`` there); every
decision of an agent is trained on, including one whose option the episode's end cut short.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import torch
from torch import Tensor, nn

from maopg.env.contract import EnvSpec
from maopg.env.vector import SeededVectorEnv
from maopg.learner.adam import Adam
from maopg.learner.base import (
    Actor,
    Learner,
    LearnerSetup,
    episode_metrics,
    require_finite,
    require_finite_parameters,
)
from maopg.learner.gae import DiscountForm, compute_gae
from maopg.learner.rounds import Episodes, collect_round, mix_agents
from maopg.policy import (
    DistributionActor,
    set_precision,
)
from maopg.policy.agent_centric import AgentCentricCritic, AgentCentricPolicy, scan
from maopg.policy.joint_size import BuildTarget
from maopg.settings import Settings, setting


@dataclass
class ACACConfig(Settings):
    """The ``acac.*`` settings; defaults are the published runs' (Box Pushing, reference §10)."""

    lr: float = setting(3e-4, gt=0.0)
    """Each actor's Adam learning rate."""
    critic_lr: float = setting(3e-4, gt=0.0)
    clip: float = setting(0.05, gt=0.0)
    """PPO's ratio clip."""
    train_repeat: int = setting(2, ge=1)
    """Full-batch gradient steps of the critic and of each actor per round."""
    gae_lambda: float = setting(0.95, ge=0.0, le=1.0)
    episodes_per_update: int = setting(16, ge=1)
    """Finished episodes a round waits for and trains on (the last ones to finish)."""
    target_every: int = setting(64, ge=1)
    """Episodes of the counter between copies of the critic into the target critic."""
    explore_eps: float = setting(1.0, ge=0.0, le=1.0)
    """ε of the mixture at the first round (0: no exploration)."""
    explore_eps_end: float = setting(0.01, ge=0.0, le=1.0)
    explore_decay: int = setting(30_000, ge=1)
    """Episodes of the counter over which ε falls linearly to ``explore_eps_end``."""
    width: int = setting(32, ge=1)
    """Width of every layer of the actors and the critic."""
    heads: int = setting(2, ge=1)
    """Attention heads of the critic (``width`` must be a multiple)."""
    popart_beta: float = setting(0.99999, gt=0.0, lt=1.0)

    def validate(self) -> None:
        if self.width % self.heads:
            raise ValueError(
                f"acac.width ({self.width}) must be a multiple of acac.heads ({self.heads})"
            )

    def exploration(self, episodes: int) -> float:
        """ε after ``episodes`` episodes of the counter."""
        if not self.explore_eps:
            return 0.0
        fraction = min(episodes / self.explore_decay, 1.0)
        return self.explore_eps + (self.explore_eps_end - self.explore_eps) * fraction


class ACACLearner(Learner):
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
    policy_key = "policy"

    def __init__(self, policy: AgentCentricPolicy, setup: LearnerSetup) -> None:
        super().__init__(policy, setup)
        cfg: ACACConfig = self.config
        self.critic = AgentCentricCritic(
            setup.spec, width=cfg.width, heads=cfg.heads, popart_beta=cfg.popart_beta
        ).to(self.device)
        set_precision(self.critic, setup.precision)
        self.target = copy.deepcopy(self.critic)
        self.actor_opts = [
            Adam([*net.parameters(), *cell.parameters(), *head.parameters()], lr=cfg.lr)
            for net, cell, head in zip(policy.inputs, policy.cells, policy.heads, strict=True)
        ]
        self.critic_opt = Adam(self.critic.parameters(), lr=cfg.critic_lr)
        self.episodes = 0
        """The episode counter: ``episodes_per_update`` a round (ε and the target's copies)."""
        self.published_steps = 0

    def iteration(self, envs: SeededVectorEnv, samples: int) -> tuple[dict[str, Any], int]:
        cfg: ACACConfig = self.config
        epsilon = cfg.exploration(self.episodes)
        batch, finished, ticks = self.collect(envs, epsilon)
        self.published_steps += sum(e["ticks"] for e in finished)
        stats = self.update(batch, epsilon)
        before, self.episodes = self.episodes, self.episodes + cfg.episodes_per_update
        if self.episodes // cfg.target_every > before // cfg.target_every:
            self.target.load_state_dict(self.critic.state_dict())
        row = {
            "option_steps": int(batch.steps.sum()),
            **episode_metrics(finished),
            "option_step_reward": float(batch.reward_sum[batch.steps.numpy()].mean()),
            **stats,
            "epsilon": epsilon,
            "published_steps": self.published_steps,
        }
        return row, ticks

    @torch.no_grad()
    def collect(
        self, envs: SeededVectorEnv, epsilon: float
    ) -> tuple[Episodes, list[dict[str, Any]], int]:
        """One round (:func:`~maopg.learner.rounds.collect_round`)."""
        return collect_round(
            envs,
            self.policy,
            epsilon,
            self.config.episodes_per_update,
            self.setup.sample_gen,
            self.device,
        )

    def _agent_log_probs(self, batch: Episodes, epsilon: float) -> tuple[list[Tensor], Tensor]:
        """Each agent's ε-mixed log-probability ``[T, B]`` of its option at every point, and the
        policy's own entropy ``[T, B]`` there (summed over the choosing agents)."""
        steps, width = batch.choosing.shape[:2], self.policy.width
        obs = batch.obs.to(self.device)
        states = scan(
            self.policy.cells,
            [net(obs) for net in self.policy.inputs],
            batch.choosing.to(self.device),
            batch.starts.to(self.device),
            torch.zeros(steps[1], len(self.policy.cells), width, device=self.device),
        )
        flat = states.flatten(0, 1)
        dist = self.policy.heads_at(
            flat,
            batch.choosing.flatten(0, 1).to(self.device),
            batch.running.flatten(0, 1).to(self.device),
            batch.available.flatten(0, 1).to(self.device),
        )
        entropy = dist.entropy().view(steps)
        if epsilon:
            dist = mix_agents(dist, epsilon)
        joint = batch.joint.flatten(0, 1).to(self.device)
        log_probs = [
            lp.gather(-1, joint[:, i : i + 1]).squeeze(-1).view(steps)
            for i, lp in enumerate(dist.agent_log_probs)
        ]
        return log_probs, entropy

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
        return compute_gae(
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
            old, _ = self._agent_log_probs(batch, epsilon)
        deciding = batch.choosing.to(self.device) & steps.unsqueeze(-1)
        sums = dict.fromkeys(("policy_loss", "value_loss", "entropy", "approx_kl"), 0.0)
        for _ in range(cfg.train_repeat):
            value_loss = (self._values(self.critic, batch) - targets)[steps].square().mean()
            self._descend(value_loss, self.critic, self.critic_opt, "critic")
            sums["value_loss"] += value_loss.item()
            new, entropy = self._agent_log_probs(batch, epsilon)
            sums["entropy"] += entropy[steps].mean().item()
            actor_losses = []
            for i, optimizer in enumerate(self.actor_opts):
                mine = deciding[..., i]
                if not bool(mine.any()):
                    continue
                log_ratio = (new[i] - old[i])[mine]
                ratio = log_ratio.exp()
                a = advantage[mine]
                surrogate = torch.min(ratio * a, ratio.clamp(1 - cfg.clip, 1 + cfg.clip) * a)
                actor_losses.append((-surrogate.mean(), optimizer, log_ratio))
            for loss, optimizer, _ in actor_losses:
                require_finite(loss, "an actor's loss")
                optimizer.zero_grad()
            sum(loss for loss, _, _ in actor_losses).backward()
            for _, optimizer, _ in actor_losses:
                optimizer.step()
            sums["policy_loss"] += float(np.mean([loss.item() for loss, _, _ in actor_losses]))
            kl = torch.cat([((r.exp() - 1) - r).detach() for _, _, r in actor_losses]).mean()
            sums["approx_kl"] += kl.item()
        require_finite_parameters(self.policy, "the actors")
        require_finite_parameters(self.critic, "the critic")
        return {key: total / cfg.train_repeat for key, total in sums.items()}

    @staticmethod
    def _descend(loss: Tensor, network: nn.Module, optimizer: Adam, name: str) -> None:
        require_finite(loss, f"the {name}'s loss")
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()

    def final_state(self) -> dict[str, Any]:
        return {"policy": self.policy.state_dict(), "critic": self.critic.state_dict()}

    def state_dict(self) -> dict[str, Any]:
        return {
            **self.final_state(),
            "target": self.target.state_dict(),
            "actor_opts": [o.state_dict() for o in self.actor_opts],
            "critic_opt": self.critic_opt.state_dict(),
            "episodes": self.episodes,
            "published_steps": self.published_steps,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.policy.load_state_dict(state["policy"])
        self.critic.load_state_dict(state["critic"])
        self.target.load_state_dict(state["target"])
        for optimizer, saved in zip(self.actor_opts, state["actor_opts"], strict=True):
            optimizer.load_state_dict(saved)
        self.critic_opt.load_state_dict(state["critic_opt"])
        self.episodes = int(state["episodes"])
        self.published_steps = int(state["published_steps"])

    @staticmethod
    def actor(policy: nn.Module, config: Any, *, greedy: bool, seed: int) -> Actor:
        return DistributionActor(policy, greedy=greedy, seed=seed)  # type: ignore[arg-type]


def agent_centric_policy(
    spec: EnvSpec, *, hidden: int, layers: int, config: ACACConfig, target: BuildTarget
) -> AgentCentricPolicy:
    """ACAC's actors at ``acac.width`` (the run's ``hidden``/``layers`` size maopg's own
    networks; ACAC's are the published 32-wide ones)."""
    del hidden, layers, target
    return AgentCentricPolicy(spec, width=config.width)

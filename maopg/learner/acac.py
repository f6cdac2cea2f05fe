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
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import torch
from torch import Tensor, nn

from maopg.env.contract import DecisionPoint, EnvSpec
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
from maopg.policy import (
    DistributionActor,
    ObsBatch,
    episode_starts,
    set_precision,
    stack_conditions,
)
from maopg.policy.agent_centric import AgentCentricCritic, AgentCentricPolicy, scan
from maopg.policy.conditional import FactoredConditional, mix_uniform
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


@dataclass
class Episodes:
    """A round's training batch: ``B`` finished episodes as ``[T, B]`` grids over their decision
    points, row ``J_b`` of episode ``b`` its final point (padding after it: ``valid`` false)."""

    obs: ObsBatch
    """``T * B`` rows, time-major."""
    choosing: Tensor
    """``bool [T, B, N]``."""
    running: Tensor
    available: Tensor
    joint: Tensor
    """``int64 [T, B, N]``: the joint option taken at each decision point."""
    reward: np.ndarray
    """``[T, B]``: the discounted reward of the step from each point."""
    reward_sum: np.ndarray
    """``[T, B]``: its summed reward."""
    duration: np.ndarray
    terminated: np.ndarray
    """``bool [B]``: the episode ended in a terminal state (else a timeout)."""
    length: np.ndarray
    """``int [B]``: decision points ``J_b`` before the final point."""

    @property
    def steps(self) -> Tensor:
        """``bool [T, B]``: rows that are a step (a decision point that was acted on)."""
        t = torch.arange(self.choosing.shape[0]).unsqueeze(1)
        return t < torch.from_numpy(self.length).unsqueeze(0)

    @property
    def starts(self) -> Tensor:
        starts = torch.zeros(self.choosing.shape[:2], dtype=torch.bool)
        starts[0] = True
        return starts


def _episodes(rows: list[list[tuple[DecisionPoint, np.ndarray]]], finals: list) -> Episodes:
    """Stack episodes given as ``(point, joint)`` rows plus each one's final point."""
    longest = max(len(r) for r in rows) + 1
    n = len(finals[0].choosing)
    points, joints = [], []
    filler = finals[0]
    for episode, final in zip(rows, finals, strict=True):
        seq = [p for p, _ in episode] + [final]
        points.append(seq + [filler] * (longest - len(seq)))
        joints.append([j for _, j in episode] + [np.zeros(n, np.int64)] * (longest - len(episode)))
    by_time = [points[b][t] for t in range(longest) for b in range(len(rows))]
    obs = ObsBatch.from_decision_points(by_time)
    choosing, running, available = (
        c.view(longest, len(rows), -1) for c in stack_conditions(by_time)
    )
    reward = np.zeros((longest, len(rows)))
    reward_sum = np.zeros((longest, len(rows)))
    duration = np.ones((longest, len(rows)))
    for b, seq in enumerate(points):
        for t, point in enumerate(seq[1 : len(rows[b]) + 1]):
            reward[t, b] = point.discounted_reward
            reward_sum[t, b] = point.reward
            duration[t, b] = point.duration
    joint = torch.from_numpy(np.stack([np.stack(j) for j in joints], axis=1))
    terminated = np.array([f.terminated for f in finals])
    length = np.array([len(r) for r in rows])
    return Episodes(
        obs, choosing, running, available, joint, reward, reward_sum, duration, terminated, length
    )


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
        """One round (module docstring): the batch, the info of every episode that finished in
        the round, the ticks simulated.

        ACAC's environments advance a tick at a time and its round stops at the first tick by
        which ``episodes_per_update`` episodes have finished; these advance a decision point at
        a time, each by its own option's ticks. So every finish is kept with the round tick it
        came at, the environments step until none can still finish at or before the tick of
        the ``episodes_per_update``-th earliest finish (every one has passed it), and the round
        is what ACAC's would have been: the episodes finished by then, ordered by tick (then
        environment), the last ``episodes_per_update`` of them its batch. The ticks simulated
        past that tick are in the count all the same."""
        cfg: ACACConfig = self.config
        wanted = cfg.episodes_per_update
        envs.restart()
        state = self.policy.initial_state(envs.num_envs).to(self.device)
        open_rows: list[list[tuple[DecisionPoint, np.ndarray]]] = [[] for _ in envs.points]
        finishes: list[tuple[int, int, list, DecisionPoint]] = []
        """(round tick, environment, rows, final point) of every finished episode."""
        elapsed = np.zeros(envs.num_envs, dtype=np.int64)
        cutoff = math.inf
        while elapsed.min() < cutoff:
            points = envs.points
            obs = ObsBatch.from_decision_points(points).to(self.device)
            conditions = [c.to(self.device) for c in stack_conditions(points)]
            starts = episode_starts(points).to(self.device)
            dist, state = self.policy.step(obs, *conditions, state, starts)
            if epsilon:
                dist = self._mixed(dist, epsilon)
            joint = dist.sample(self.setup.sample_gen).cpu().numpy()
            kept = [copy.deepcopy(p) for p in points]
            results = envs.step(joint)
            for e, result in enumerate(results):
                open_rows[e].append((kept[e], joint[e]))
                elapsed[e] += result.outcome.duration
                if result.final is not None:
                    final = copy.deepcopy(result.final)
                    finishes.append((int(elapsed[e]), e, open_rows[e], final))
                    open_rows[e] = []
            if len(finishes) >= wanted:
                cutoff = sorted(f[0] for f in finishes)[wanted - 1]
        done = sorted((f for f in finishes if f[0] <= cutoff), key=lambda f: (f[0], f[1]))
        batch = _episodes([f[2] for f in done[-wanted:]], [f[3] for f in done[-wanted:]])
        infos = [dict(f[3].info["episode"]) for f in done]
        return batch, infos, int(elapsed.sum())

    @staticmethod
    def _mixed(dist: FactoredConditional, epsilon: float) -> FactoredConditional:
        """``dist`` with each choosing agent's factor mixed with the uniform over its available
        options, ``(1 − ε) π_i + ε / |A_i|``."""
        eps = torch.full((len(dist.choosing),), epsilon, device=dist.choosing.device)
        mixed = [
            torch.where(dist.choosing[:, i : i + 1], mix_uniform(lp, eps), lp)
            for i, lp in enumerate(dist.agent_log_probs)
        ]
        return FactoredConditional(mixed, dist.choosing, dist.running)

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
            dist = self._mixed(dist, epsilon)
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

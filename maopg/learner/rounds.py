"""Whole episodes collected in rounds, as the macro-action actor-critic literature trains
(ACAC, Mac-IAICC and its siblings: MacroMARL's runner): every environment restarts at each
round, all step in lockstep until enough episodes have finished, the last of them are the
batch, and the unfinished are dropped. Learners that train this way share it
(:mod:`maopg.learner.acac`, :mod:`maopg.learner.mac_iaicc`)."""

from __future__ import annotations

import copy
import math
from abc import abstractmethod
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from maopg.env.contract import DecisionPoint
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
from maopg.policy import (
    DistributionActor,
    ObsBatch,
    OptionPolicy,
    episode_starts,
    set_precision,
    stack_conditions,
)
from maopg.policy.agent_centric import AgentCentricPolicy, scan
from maopg.policy.conditional import FactoredConditional, mix_uniform


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
    def deciding(self) -> Tensor:
        """``bool [T, B, N]``: the agents that chose at each step."""
        return self.choosing & self.steps.unsqueeze(-1)

    @property
    def starts(self) -> Tensor:
        starts = torch.zeros(self.choosing.shape[:2], dtype=torch.bool)
        starts[0] = True
        return starts


def stack_episodes(rows: list[list[tuple[DecisionPoint, np.ndarray]]], finals: list) -> Episodes:
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


def collect_round(
    envs: SeededVectorEnv,
    policy: OptionPolicy,
    epsilon: float,
    wanted: int,
    generator: torch.Generator,
    device: torch.device,
) -> tuple[Episodes, list[dict[str, Any]], int]:
    """One round: every environment starts a new episode and all step in lockstep, ``policy``'s
    choosing agents drawing from ``(1 − ε) π_i + ε / |A_i|`` (:func:`mix_agents`), until the tick
    by which ``wanted`` episodes have finished; returns the last ``wanted`` to finish as the
    batch, the info of every episode that finished in the round, the ticks simulated.

    The literature's environments advance a tick at a time and a round stops at the first tick
    by which ``wanted`` episodes have finished; these advance a decision point at a time, each
    by its own option's ticks. So every finish is kept with the round tick it came at, the
    environments step until none can still finish at or before the tick of the ``wanted``-th
    earliest finish (every one has passed it), and the round is what theirs would have been:
    the episodes finished by then, ordered by tick (then environment), the last ``wanted`` of
    them the batch. The ticks simulated past that tick are in the count all the same."""
    envs.restart()
    state = policy.initial_state(envs.num_envs)
    state = None if state is None else state.to(device)
    open_rows: list[list[tuple[DecisionPoint, np.ndarray]]] = [[] for _ in envs.points]
    finishes: list[tuple[int, int, list, DecisionPoint]] = []
    """(round tick, environment, rows, final point) of every finished episode."""
    elapsed = np.zeros(envs.num_envs, dtype=np.int64)
    cutoff = math.inf
    while elapsed.min() < cutoff:
        points = envs.points
        obs = ObsBatch.from_decision_points(points).to(device)
        conditions = [c.to(device) for c in stack_conditions(points)]
        starts = episode_starts(points).to(device)
        dist, state = policy.step(obs, *conditions, state, starts)
        if epsilon:
            dist = mix_agents(dist, epsilon)  # type: ignore[arg-type]
        joint = dist.sample(generator).cpu().numpy()
        results = envs.step(joint)  # new points: those kept are not changed
        for e, result in enumerate(results):
            open_rows[e].append((points[e], joint[e]))
            elapsed[e] += result.outcome.duration
            if result.final is not None:
                finishes.append((int(elapsed[e]), e, open_rows[e], result.final))
                open_rows[e] = []
        if len(finishes) >= wanted:
            cutoff = sorted(f[0] for f in finishes)[wanted - 1]
    done = sorted((f for f in finishes if f[0] <= cutoff), key=lambda f: (f[0], f[1]))
    batch = stack_episodes([f[2] for f in done[-wanted:]], [f[3] for f in done[-wanted:]])
    infos = [dict(f[3].info["episode"]) for f in done]
    return batch, infos, int(elapsed.sum())


def mix_agents(dist: FactoredConditional, epsilon: float) -> FactoredConditional:
    """``dist`` with each choosing agent's factor mixed with the uniform over its available
    options, ``(1 − ε) π_i + ε / |A_i|``."""
    eps = torch.full((len(dist.choosing),), epsilon, device=dist.choosing.device)
    mixed = [
        torch.where(dist.choosing[:, i : i + 1], mix_uniform(lp, eps), lp)
        for i, lp in enumerate(dist.agent_log_probs)
    ]
    return FactoredConditional(mixed, dist.choosing, dist.running)


class RoundsLearner(Learner):
    """What ACAC and the MacroMARL actor-critics share: recurrent actors, one per agent
    (:class:`~maopg.policy.agent_centric.AgentCentricPolicy`), each with its Adam; a critic of the
    subclass's with its Adam and a target copy refreshed every ``target_every`` episodes of the
    counter; rounds of :func:`collect_round` with ε from the counter, which grows by
    ``episodes_per_update`` a round. The config section has ``lr``, ``critic_lr``,
    ``episodes_per_update``, ``target_every`` and ``exploration(episodes)``; a subclass gives
    its critic and :meth:`update`."""

    policy_key = "policy"

    def __init__(self, policy: AgentCentricPolicy, setup: LearnerSetup, critic: nn.Module) -> None:
        super().__init__(policy, setup)
        cfg = self.config
        self.critic = critic.to(self.device)
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
        """The summed length of the finished training episodes so far (the literature's
        counter)."""

    def iteration(self, envs: SeededVectorEnv, samples: int) -> tuple[dict[str, Any], int]:
        cfg = self.config
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
        """One round (:func:`collect_round`)."""
        return collect_round(
            envs,
            self.policy,  # type: ignore[arg-type]
            epsilon,
            self.config.episodes_per_update,
            self.setup.sample_gen,
            self.device,
        )

    @abstractmethod
    def update(self, batch: Episodes, epsilon: float) -> dict[str, float]:
        """Learn from one round's batch, collected at ``epsilon``; the loss statistics."""

    def agent_log_probs(self, batch: Episodes, epsilon: float) -> tuple[list[Tensor], Tensor]:
        """Each agent's ε-mixed log-probability ``[T, B]`` of its option at every point, and the
        policy's own entropy ``[T, B]`` there (summed over the choosing agents)."""
        device, steps = self.device, batch.choosing.shape[:2]
        policy: AgentCentricPolicy = self.policy  # type: ignore[assignment]
        obs = batch.obs.to(device)
        states = scan(
            policy.cells,
            [net(obs) for net in policy.inputs],
            batch.choosing.to(device),
            batch.starts.to(device),
            policy.initial_state(steps[1]).to(device),
        )
        dist = policy.heads_at(
            states.flatten(0, 1),
            batch.choosing.flatten(0, 1).to(device),
            batch.running.flatten(0, 1).to(device),
            batch.available.flatten(0, 1).to(device),
        )
        entropy = dist.entropy().view(steps)
        if epsilon:
            dist = mix_agents(dist, epsilon)
        chosen = batch.joint.flatten(0, 1).to(device)
        log_probs = [
            lp.gather(-1, chosen[:, i : i + 1]).squeeze(-1).view(steps)
            for i, lp in enumerate(dist.agent_log_probs)
        ]
        return log_probs, entropy

    def step_critic(self, loss: Tensor) -> None:
        """One Adam step of the critic on ``loss`` (no gradient clipping, as published)."""
        require_finite(loss, "the critic's loss")
        self.critic_opt.zero_grad()
        loss.backward()
        self.critic_opt.step()

    def step_actors(self, losses: dict[int, Tensor]) -> None:
        """One Adam step of each agent's actor on its own loss (agents absent: no step)."""
        for loss in losses.values():
            require_finite(loss, "an actor's loss")
        for agent in losses:
            self.actor_opts[agent].zero_grad()
        sum(losses.values()).backward()  # type: ignore[union-attr]
        for agent in losses:
            self.actor_opts[agent].step()

    def require_finite_networks(self) -> None:
        require_finite_parameters(self.policy, "the actors")
        require_finite_parameters(self.critic, "the critic")

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

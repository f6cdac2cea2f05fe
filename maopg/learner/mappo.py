"""MAPPO over option-level trajectories (docs/DESIGN.md §5; Yu et al. 2021's defaults): every
method but Mac-DQN. One iteration, top to bottom in :meth:`MAPPOLearner.iteration`: collect a
rollout with the conditional policy (:meth:`MAPPOLearner.collect`), compute GAE over its option
steps, run the PPO update (:class:`MAPPO`) and return the metrics row the trainer logs.

Actor and critic are separate networks with separate Adam optimisers and separate gradient-norm
clipping, as in MAPPO. The actor's objective is PPO's clipped surrogate on the ratio of
*conditional* probabilities ``π̂(o^U | c, z)``: agents that were continuing at a decision point have
probability 1 given the condition and so contribute nothing to the ratio or the entropy — that is
the paper's conditional policy gradient. The critic regresses normalised value targets with a
Huber loss, clipped around the old prediction like the policy ratio.

With ``ppo.recurrent`` both networks carry a GRU state over the decision points
(:mod:`maopg.policy.memory`): the collection loop keeps each environment's states (across
iterations, and in the checkpoint) and stores them per row; the update runs over chunks of
``ppo.chunk_length`` consecutive decision points re-run from their stored states
(:meth:`MAPPO._step_inputs`), the rest of PPO unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
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
from maopg.learner.beside import Beside
from maopg.learner.buffer import Memory, Rollout, TrainBatch
from maopg.learner.sections import PPOConfig
from maopg.learner.value_norm import ValueNorm
from maopg.policy import (
    AutoregressivePolicy,
    CentralCritic,
    CentralizedPolicy,
    DistributionActor,
    JointOptionDistribution,
    MemoryDesign,
    ObsBatch,
    OptionPolicy,
    PartialFactoredPolicy,
    PartiallyCentralizedPolicy,
    episode_starts,
    explore,
    set_precision,
    stack_conditions,
)
from maopg.policy.joint_size import BuildTarget, require_joint_head_fits


@dataclass
class Losses:
    """Per-minibatch loss terms (tensors, differentiable where it matters)."""

    policy: Tensor
    value: Tensor
    entropy: Tensor
    approx_kl: Tensor
    clip_fraction: Tensor


@dataclass(frozen=True)
class _StepInputs:
    """One minibatch's inputs to a PPO step: the two networks' forward passes, deferred so that
    each runs on the thread that takes its gradient step, and the rows' recorded quantities."""

    distribution: Callable[[], JointOptionDistribution]
    values: Callable[[], Tensor]
    joint: Tensor
    old_log_prob: Tensor
    old_value: Tensor
    advantages: Tensor
    targets: Tensor

    def actor_terms(self, cfg: PPOConfig) -> dict[str, Tensor]:
        """The clipped surrogate (as a loss), the entropy and the ratio's statistics."""
        dist = self.distribution()
        log_prob = dist.log_prob(self.joint)
        log_ratio = log_prob - self.old_log_prob
        ratio = log_ratio.exp()
        advantages = self.advantages
        surrogate = torch.min(
            ratio * advantages, ratio.clamp(1.0 - cfg.clip, 1.0 + cfg.clip) * advantages
        )
        with torch.no_grad():
            approx_kl = ((ratio - 1.0) - log_ratio).mean()
            clip_fraction = ((ratio - 1.0).abs() > cfg.clip).float().mean()
        return {
            "policy_loss": -surrogate.mean(),
            "entropy": dist.entropy().mean(),
            "approx_kl": approx_kl,
            "clip_fraction": clip_fraction,
        }

    def value_loss(self, cfg: PPOConfig) -> Tensor:
        """The Huber loss of the values and of the values clipped around the old prediction,
        whichever is larger (MAPPO's clipped value loss)."""
        values, old_value, targets = self.values(), self.old_value, self.targets
        clipped = old_value + (values - old_value).clamp(-cfg.value_clip, cfg.value_clip)
        huber = nn.functional.huber_loss
        return torch.max(
            huber(values, targets, reduction="none", delta=cfg.huber_delta),
            huber(clipped, targets, reduction="none", delta=cfg.huber_delta),
        ).mean()

    def losses(self, cfg: PPOConfig) -> Losses:
        terms = self.actor_terms(cfg)
        return Losses(
            policy=terms["policy_loss"],
            value=self.value_loss(cfg),
            entropy=terms["entropy"],
            approx_kl=terms["approx_kl"],
            clip_fraction=terms["clip_fraction"],
        )


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
        self.policy_opt = Adam(policy.parameters(), lr=config.lr, eps=config.adam_eps)
        self.critic_opt = Adam(critic.parameters(), lr=config.critic_lr, eps=config.adam_eps)
        self.overlap_critic = True
        """The critic's steps on a thread of their own beside the actor's
        (:mod:`maopg.learner.beside`: the same bits either way; 1.13-1.84x faster updates,
        ``bench/perf/learner_plumbing.py``)."""

    def value_targets(self, returns: Tensor) -> Tensor:
        """Returns in the critic's space (normalised when value normalisation is on)."""
        return returns if self.value_norm is None else self.value_norm.normalize(returns)

    def losses(self, batch: TrainBatch, advantages: Tensor, targets: Tensor) -> Losses:
        """PPO losses of ``batch`` given its (normalised) advantages and critic-space targets."""
        return self._step_inputs(batch, None, advantages, targets).losses(self.config)

    def _step_inputs(
        self, batch: TrainBatch, chunks: Tensor | None, advantages: Tensor, targets: Tensor
    ) -> _StepInputs:
        """What one PPO step reads: ``batch``'s rows (feed-forward) or the decision points of
        ``chunks`` (``int64 [C, L]`` rows of ``batch``, ``-1`` padding; :meth:`TrainBatch.chunks`)
        for a recurrent policy and critic, with the whole batch's ``advantages`` and
        ``targets``: both re-run each chunk from the states stored at its first row, resets
        masked inside it, and the gradient flows back through the chunk."""
        policy, critic = self.policy, self.critic
        if chunks is None:
            obs = batch.obs
            return _StepInputs(
                lambda: self.explored(
                    policy.distribution(obs, batch.choosing, batch.running, batch.available),
                    batch.epsilon,
                    (batch.choosing, batch.running, batch.available),
                ),
                lambda: critic(obs),
                batch.joint,
                batch.old_log_prob,
                batch.old_value,
                advantages,
                targets,
            )
        valid = chunks >= 0
        padded = torch.where(valid, chunks, chunks[:, :1]).flatten()
        rows = batch.rows(padded)
        starts = batch.starts[padded].view(valid.shape)  # type: ignore[index]
        first = chunks[:, 0]
        policy_state = batch.policy_state[first]  # type: ignore[index]
        critic_state = batch.critic_state[first]  # type: ignore[index]
        kept = chunks[valid]
        return _StepInputs(
            lambda: self.explored(
                policy.sequence(
                    rows.obs,
                    rows.choosing,
                    rows.running,
                    rows.available,
                    policy_state,
                    starts,
                    valid,
                ),
                None if batch.epsilon is None else batch.epsilon[kept],
                (batch.choosing[kept], batch.running[kept], batch.available[kept]),
            ),
            lambda: critic.sequence(
                rows.obs, critic_state, starts, valid, rows.choosing, rows.running
            ),
            batch.joint[kept],
            batch.old_log_prob[kept],
            batch.old_value[kept],
            advantages[kept],
            targets[kept],
        )

    def explored(
        self,
        dist: JointOptionDistribution,
        epsilon: float | Tensor | None,
        conditions: tuple[Tensor, Tensor, Tensor],
    ) -> JointOptionDistribution:
        """``dist`` mixed with exploration of weight ``epsilon`` (``None``: none) in the
        configured form (``ppo.explore_form``), for decision points with ``conditions``."""
        if epsilon is None:
            return dist
        form = self.config.explore_form
        counts = self.policy.option_counts
        return explore(dist, epsilon, form, conditions, counts)

    def _actor_step(self, inputs: _StepInputs, ent_coef: float) -> dict[str, float]:
        """One gradient step of the policy on PPO's clipped surrogate plus the entropy bonus
        weighted by ``ent_coef``."""
        terms = inputs.actor_terms(self.config)
        actor_loss = terms["policy_loss"] - ent_coef * terms["entropy"]
        self._descend(actor_loss, self.policy, self.policy_opt, "actor")
        return {key: term.item() for key, term in terms.items()}

    def _critic_step(self, inputs: _StepInputs) -> float:
        """One gradient step of the critic on the clipped Huber value loss."""
        cfg = self.config
        value_loss = inputs.value_loss(cfg)
        self._descend(cfg.value_coef * value_loss, self.critic, self.critic_opt, "critic")
        return value_loss.item()

    def _descend(self, loss: Tensor, network: nn.Module, optimizer: Adam, name: str) -> None:
        """One Adam step of ``network`` on ``loss`` with its gradient norm clipped; a non-finite
        loss or gradient stops it before the step (:func:`require_finite`)."""
        require_finite(loss, f"the {name}'s loss")
        optimizer.zero_grad()
        loss.backward()
        norm = nn.utils.clip_grad_norm_(network.parameters(), self.config.max_grad_norm)
        require_finite(norm, f"the {name}'s gradient norm")
        optimizer.step()

    def update(
        self, batch: TrainBatch, generator: torch.Generator, *, samples: int = 0
    ) -> dict[str, float]:
        """Run ``epochs`` passes of ``num_minibatches`` shuffled minibatches over ``batch``: of
        its rows, or for a recurrent policy of its chunks of ``chunk_length`` consecutive
        decision points of one environment (:meth:`TrainBatch.chunks`). ``samples``, the ticks
        trained before this batch, sets the entropy bonus's weight
        (:meth:`PPOConfig.entropy_coef`).

        Updates the value normaliser with the batch's returns first (MAPPO), so the critic's
        targets are normalised with statistics that include them. Returns mean statistics.
        A non-finite loss or gradient stops it before the step that would spread it, a
        non-finite weight after the epochs (:class:`~maopg.learner.base.NonFiniteError`).

        The critic's step runs beside the actor's (:attr:`overlap_critic`): advantages and
        targets are fixed before the epochs, and neither step writes what the other reads.
        """
        cfg = self.config
        ent_coef = cfg.entropy_coef(samples)
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
        chunks = batch.chunks(cfg.chunk_length) if self.policy.recurrent else None
        size = len(batch) if chunks is None else len(chunks)
        num_minibatches = max(1, min(cfg.num_minibatches, size))
        with Beside(self.overlap_critic) as beside:
            for _ in range(cfg.epochs):
                # The generator is a CPU one (LearnerSetup.device): draw there, index on the device.
                order = torch.randperm(size, generator=generator).to(advantages.device)
                for index in order.tensor_split(num_minibatches):
                    if chunks is None:
                        inputs = self._step_inputs(
                            batch.rows(index), None, advantages[index], targets[index]
                        )
                    else:
                        inputs = self._step_inputs(batch, chunks[index], advantages, targets)
                    value_loss, stats = beside.run(
                        partial(self._critic_step, inputs),
                        partial(self._actor_step, inputs, ent_coef),
                    )
                    stats["value_loss"] = value_loss
                    for key, value in stats.items():
                        sums[key] += value
                    updates += 1
        require_finite_parameters(self.policy, "the actor")
        require_finite_parameters(self.critic, "the critic")
        return {key: total / updates for key, total in sums.items()}

    def state_dict(self) -> dict[str, dict]:
        return {
            "policy_opt": self.policy_opt.state_dict(),
            "critic_opt": self.critic_opt.state_dict(),
        }

    def load_state_dict(self, state: dict[str, dict]) -> None:
        self.policy_opt.load_state_dict(state["policy_opt"])
        self.critic_opt.load_state_dict(state["critic_opt"])


def memory_design(config: Any) -> MemoryDesign:
    """A config section's ``recurrent``, ``option_history`` and ``memory_norm`` as the networks'
    :class:`~maopg.policy.memory.MemoryDesign`: the policy builders below serve any learner,
    and a user's learner whose section has no such fields (it is feed-forward) may reuse them."""
    return MemoryDesign(
        recurrent=bool(getattr(config, "recurrent", False)),
        option_history=bool(getattr(config, "option_history", False)),
        norm=bool(getattr(config, "memory_norm", False)),
    )


PRODUCT_WAY_OUT = (
    "the product categorical grows as ΠK_i; the chain-rule methods (async-ar, sync-cut-ar, "
    "partial-ar) grow linearly in the team"
)


def update_rows(config: Any, target: BuildTarget) -> int:
    """Rows of joint logits an update over a product categorical holds at once: a
    minibatch's decision points (at most about one per tick of the ``target`` run's batch)
    times the logits, their log-softmax and its gradient. ``config`` is the learner's section:
    a user's learner that reuses these builders may have no ``num_minibatches`` (one
    minibatch, then)."""
    minibatches = int(getattr(config, "num_minibatches", 1))
    return 3 * max(1, target.batch_ticks // minibatches)


def centralized_policy(
    spec: EnvSpec, *, hidden: int, layers: int, config: PPOConfig, target: BuildTarget
) -> CentralizedPolicy:
    """The paper's conditional centralized policy (the method registry's policy builder); a
    team whose joint option set cannot fit is refused before anything is allocated
    (:mod:`maopg.policy.joint_size`)."""
    require_joint_head_fits(
        spec.option_counts,
        hidden=hidden,
        copies=4,  # weights, gradient, Adam's two moments
        rows=update_rows(config, target),
        who="the centralized policy",
        instead=PRODUCT_WAY_OUT,
        target=target,
    )
    return CentralizedPolicy(spec, hidden=hidden, layers=layers, memory=memory_design(config))


def autoregressive_policy(
    spec: EnvSpec, *, hidden: int, layers: int, config: PPOConfig, target: BuildTarget
) -> AutoregressivePolicy:
    """The same conditional, factored by the chain rule: one small factor per choosing agent
    (linear in the team size, where the product categorical grows as ``ΠK_i``)."""
    return AutoregressivePolicy(spec, hidden=hidden, layers=layers, memory=memory_design(config))


def partial_factored_policy(
    spec: EnvSpec, *, hidden: int, layers: int, config: PPOConfig, target: BuildTarget
) -> PartialFactoredPolicy:
    """The partially centralized policy with one factor per agent instead of joint logits
    (linear in the team size, where ``partial``'s heads grow as ``ΠK_i``)."""
    return PartialFactoredPolicy(spec, hidden=hidden, layers=layers, memory=memory_design(config))


def partial_policy(
    spec: EnvSpec, *, hidden: int, layers: int, config: PPOConfig, target: BuildTarget
) -> PartiallyCentralizedPolicy:
    """One policy per agent from its local observation (paper §III-D), each with joint logits
    over the whole team's options: refused, as :func:`centralized_policy`, where they cannot
    fit."""
    require_joint_head_fits(
        spec.option_counts,
        hidden=hidden,
        copies=4 * len(spec.option_counts),  # each agent's head: weights, gradient, Adam's two
        rows=len(spec.option_counts) * update_rows(config, target),
        who="the partially centralized policy",
        instead=PRODUCT_WAY_OUT,
        target=target,
    )
    return PartiallyCentralizedPolicy(
        spec, hidden=hidden, layers=layers, memory=memory_design(config)
    )


@dataclass(frozen=True)
class _Points:
    """The environments' decision points as the collection reads them: observations on the CPU
    (kept in the rollout) and on the learner's device, which points open an episode, and their
    conditions ``(choosing, running, available)`` on the CPU."""

    obs: ObsBatch
    on_device: ObsBatch
    starts: Tensor
    conditions: tuple[Tensor, Tensor, Tensor]

    @classmethod
    def of(cls, points: Sequence[DecisionPoint], device: torch.device) -> _Points:
        obs = ObsBatch.from_decision_points(points)
        return cls(obs, obs.to(device), episode_starts(points), stack_conditions(points))

    def history(self, device: torch.device) -> tuple[Tensor, Tensor]:
        """``(choosing, running)`` on ``device``: what a critic's option history reads."""
        return self.conditions[0].to(device), self.conditions[1].to(device)


class MAPPOLearner(Learner):
    """Collect option steps with the conditional policy, GAE, the PPO update (module docstring).

    The critic ``V(z)`` on the joint observation has its own encoder, built after the policy
    from torch's global RNG (seeded by the trainer).
    """

    Config = PPOConfig
    section = "ppo"
    columns: ClassVar[tuple[str, ...]] = (
        "policy_loss",
        "value_loss",
        "entropy",
        "approx_kl",
        "clip_fraction",
        "explained_variance",
        "epsilon",
    )
    """``epsilon``: the weight of the exploration mixed into the rollout (``ppo.explore_eps``)."""
    policy_key = "policy"

    def __init__(self, policy: OptionPolicy, setup: LearnerSetup) -> None:
        design = memory_design(setup.config)
        recurrent = design.recurrent
        if policy.recurrent != recurrent:
            built = "a recurrent" if policy.recurrent else "a feed-forward"
            raise ValueError(
                f"ppo.recurrent={str(recurrent).lower()}, but the method's policy builder made "
                f"{built} {type(policy).__name__}"
            )
        super().__init__(policy, setup)
        critic = CentralCritic(setup.spec, hidden=setup.hidden, layers=setup.layers, memory=design)
        self.critic = critic.to(self.device)
        set_precision(self.critic, setup.precision)
        self.value_norm = ValueNorm().to(self.device) if self.config.value_norm else None
        self.ppo = MAPPO(policy, self.critic, self.value_norm, self.config)
        self.memory = {
            "policy": self.policy.initial_state(setup.num_envs),
            "critic": self.critic.initial_state(setup.num_envs),
        }
        """Recurrent only (else ``None``s): the states carried into each environment's current
        decision point, kept from one iteration to the next (and in the checkpoint), since the
        environments' episodes run on across iterations. The environments never see them."""
        self.episodes = 0
        """Training episodes finished so far: what ``ppo.explore_unit=episodes`` counts."""

    def iteration(self, envs: SeededVectorEnv, samples: int) -> tuple[dict[str, Any], int]:
        cfg = self.config
        epsilon = cfg.exploration(samples, self.episodes)
        rollout = self.collect(envs, epsilon, scored_mixed=cfg.explore_ratio == "mixture")
        self.episodes += len(rollout.episodes)
        advantages, returns, values = rollout.advantages(
            self.value_norm, gamma=self.setup.gamma, lam=cfg.gae_lambda, form=cfg.discount
        )
        batch = rollout.training_batch(advantages, returns).to(self.device)
        stats = self.ppo.update(batch, self.setup.update_gen, samples=samples)
        variance = float(np.var(returns))
        explained = (
            float(1.0 - np.var(returns - values) / variance) if variance > 1e-12 else math.nan
        )
        row = {
            "option_steps": rollout.num_steps * rollout.num_envs,
            **episode_metrics(rollout.episodes),
            "option_step_reward": float(np.mean(rollout.grid("reward_sum"))),
            **stats,
            "explained_variance": explained,
            "epsilon": epsilon,
        }
        return row, rollout.ticks

    @torch.no_grad()
    def collect(
        self, envs: SeededVectorEnv, epsilon: float = 0.0, *, scored_mixed: bool = True
    ) -> Rollout:
        """Step all environments in lockstep until ``batch_ticks`` ticks have been collected,
        choosing from the policy mixed with exploration of weight ``epsilon``
        (:func:`~maopg.policy.explore`); the rollout's log-probabilities are the mixture's, or
        with ``scored_mixed`` false the policy's own (``ppo.explore_ratio``).

        The last row may overshoot ``batch_ticks`` by less than one option step per
        environment; :attr:`Rollout.ticks` is the exact count. Values are stored in the
        critic's own (normalised) space; a truncated episode bootstraps from its final point.
        The networks run on the learner's device; the rollout is kept on the CPU (see
        :class:`~maopg.learner.buffer.Rollout` for why).

        Recurrent: each row also keeps the states carried into its points (a training chunk
        restarts from its first row's) and which points open an episode; the policy's state
        advances as it acts, the critic's as it values each point once (that value is the
        bootstrap of the step before and the baseline of the step after).
        """
        rollout = Rollout(num_envs=envs.num_envs, epsilon=epsilon if scored_mixed else 0.0)
        here = _Points.of(envs.points, self.device)
        policy_in, critic_in = self.memory["policy"], self.memory["critic"]
        values, critic_out = self._value(here, critic_in)
        dist, policy_out = self._act(here, policy_in)
        ticks = 0
        while ticks < self.setup.batch_ticks:
            joint, log_prob = self._choose(dist, here.conditions, epsilon, scored_mixed)
            results = envs.step(joint.numpy())
            outcomes = [r.outcome for r in results]
            ticks += int(sum(o.duration for o in outcomes))
            there = _Points.of(envs.points, self.device)
            next_values, next_critic_out = self._value(there, critic_out)
            rollout.add(
                obs=here.obs,
                choosing=here.conditions[0],
                running=here.conditions[1],
                available=here.conditions[2],
                joint=joint,
                log_prob=log_prob,
                value=values,
                reward_sum=np.array([o.reward for o in outcomes]),
                reward_discounted=np.array([o.discounted_reward for o in outcomes]),
                duration=np.array([o.duration for o in outcomes]),
                terminated=np.array([o.terminated for o in outcomes]),
                truncated=np.array([o.truncated for o in outcomes]),
                next_value=self._bootstrap(outcomes, next_values, critic_out),
                memory=None
                if policy_in is None
                else Memory(here.starts, policy_in.cpu(), critic_in.cpu()),  # type: ignore[union-attr]
            )
            rollout.episodes += [
                dict(r.final.info["episode"]) for r in results if r.final is not None
            ]
            here, values = there, next_values
            policy_in, critic_in, critic_out = policy_out, critic_out, next_critic_out
            if ticks < self.setup.batch_ticks:
                dist, policy_out = self._act(here, policy_in)
        self.memory = {"policy": policy_in, "critic": critic_in}
        return rollout

    def _act(
        self, points: _Points, state: Tensor | None
    ) -> tuple[JointOptionDistribution, Tensor | None]:
        """The policy's conditional at ``points`` and its state after them."""
        device = self.device
        conditions = (c.to(device) for c in points.conditions)
        return self.policy.step(points.on_device, *conditions, state, points.starts.to(device))

    def _choose(
        self,
        dist: JointOptionDistribution,
        conditions: tuple[Tensor, Tensor, Tensor],
        epsilon: float,
        scored_mixed: bool,
    ) -> tuple[Tensor, Tensor]:
        """A joint option drawn from ``dist`` mixed with exploration of weight ``epsilon``, and
        its log-probability under the mixture (or, not ``scored_mixed``, under ``dist``), both
        on the CPU."""
        mixed = dist
        if epsilon:  # the conditions cross to the device only when they are needed
            mixed = self.ppo.explored(dist, epsilon, tuple(c.to(self.device) for c in conditions))
        joint = mixed.sample(self.setup.sample_gen)
        log_prob = (mixed if scored_mixed else dist).log_prob(joint).cpu()
        return joint.cpu(), log_prob

    def _value(self, points: _Points, state: Tensor | None) -> tuple[Tensor, Tensor | None]:
        """The critic's values of ``points`` (on the CPU) and its state after them."""
        device = self.device
        values, state = self.critic.step(
            points.on_device, state, points.starts.to(device), *points.history(device)
        )
        return values.cpu(), state

    def _bootstrap(
        self, outcomes: Sequence[DecisionPoint], next_values: Tensor, state: Tensor | None
    ) -> Tensor:
        """What each step bootstraps from: the value of the next decision point, or of its
        episode's final point where a timeout truncated it (the critic's ``state`` carried
        into it)."""
        bootstrap = next_values.clone()
        truncated = [e for e, o in enumerate(outcomes) if o.truncated]
        if truncated:
            finals = _Points.of([outcomes[e] for e in truncated], self.device)
            carried = None if state is None else state[truncated]
            bootstrap[truncated] = self._value(finals, carried)[0]
        return bootstrap

    def final_state(self) -> dict[str, Any]:
        return {
            "policy": self.policy.state_dict(),
            "critic": self.critic.state_dict(),
            "value_norm": {} if self.value_norm is None else self.value_norm.state_dict(),
        }

    def state_dict(self) -> dict[str, Any]:
        state = {
            **self.final_state(),
            "optimizers": self.ppo.state_dict(),
            "episodes": self.episodes,
        }
        if self.policy.recurrent:
            state["memory"] = dict(self.memory)
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.policy.load_state_dict(state["policy"])
        self.critic.load_state_dict(state["critic"])
        if self.value_norm is not None:
            self.value_norm.load_state_dict(state["value_norm"])
        self.ppo.load_state_dict(state["optimizers"])
        self.episodes = state.get("episodes", 0)  # a checkpoint from before exploration: 0
        if self.policy.recurrent:
            self.memory = {key: value.to(self.device) for key, value in state["memory"].items()}

    @staticmethod
    def actor(policy: OptionPolicy, config: PPOConfig, *, greedy: bool, seed: int) -> Actor:
        return DistributionActor(policy, greedy=greedy, seed=seed)

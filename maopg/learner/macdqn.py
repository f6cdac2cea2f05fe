"""Mac-DQN: centralized macro-action deep Q-learning over asynchronous options (docs/DESIGN.md §6).

The value-based asynchronous baseline of the paper's Table I (Xiao, Hoffman & Amato 2019,
"Macro-Action-Based Deep Multi-Agent Reinforcement Learning", CoRL; their centralized
"Mac-Cen-Q" with conditional target prediction, code ``MacDeepMARL``). One Q-network maps the
joint observation ``z`` to a value for every joint option (``ΠK_i`` outputs). It learns only
from *squeezed* experience: one transition per decision point, carrying the γ-discounted reward
accumulated over the ``k`` ticks until the next decision point, so the bootstrap is
``γ^k max Q(z', ·)``.

The one twist that makes Q-learning asynchronous is the **conditional** argmax: at the next
decision point the agents that are still executing keep their options, so the maximum ranges only
over the slice where the continuing agents' entries equal their running options (and the
choosing agents' entries are available) — :func:`maopg.policy.joint_slice_mask`, the same slice
the conditional policy normalises over. Acting is the same conditional argmax, with ε-greedy
exploration drawn only among the choosing agents' available options.

Here: the config section ``dqn`` (:class:`MacDQNConfig`), the conditional double-Q update
(:class:`MacDQN`) and the learner that acts ε-greedily into the squeezed replay
(:class:`MacDQNLearner`). The Q-network is :class:`maopg.policy.JointQNetwork`, the argmax and
ε-greedy are in :mod:`maopg.policy.conditional`, the replay is :mod:`maopg.learner.replay`.

Hyper-parameters (:class:`MacDQNConfig`) name their source: the MacDeepMARL Tool Delivery command
(``ma_cen_condi_ddrqn.py --env_name=OSD_S_4 ...``) and its code defaults where they carry over,
"chosen here" where our setting differs (budgets in ticks instead of episodes, Huber loss and
gradient clipping that the original leaves off by default).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any, ClassVar

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
    mean,
    require_finite,
    require_finite_parameters,
)
from maopg.learner.replay import SqueezedReplay, point_arrays
from maopg.learner.sections import MacDQNConfig
from maopg.policy import (
    JointQNetwork,
    ObsBatch,
    QActor,
    conditional_argmax,
    epsilon_greedy,
    ravel_joint,
    stack_conditions,
)
from maopg.policy.joint_size import BuildTarget, require_joint_head_fits


# ---------------------------------------------------------------------------- the target
def double_q_target(
    *,
    reward: Tensor,
    duration: Tensor,
    terminated: Tensor,
    next_q_online: Tensor,
    next_q_target: Tensor,
    next_choosing: Tensor,
    next_running: Tensor,
    next_available: Tensor,
    option_counts: Sequence[int],
    gamma: float,
) -> Tensor:
    """``R + γ^k · Q_target(z', argmax_{slice(z')} Q_online(z', ·))``, 0 bootstrap if terminal.

    ``reward`` is the discounted sum over the ``k = duration`` ticks. A truncated transition
    bootstraps like any other (its next point is the state at the tick limit). Terminal rows
    may have no admissible next option (nothing is available once the task is over), so their
    condition is replaced by "everyone chooses anything" before the argmax; the result is
    multiplied by 0 anyway.
    """
    terminated = terminated.bool()
    done = terminated.unsqueeze(-1)
    choosing = torch.where(done, True, next_choosing.bool())
    available = torch.where(done, True, next_available.bool())
    best = conditional_argmax(next_q_online, choosing, next_running, available, option_counts)
    bootstrap = next_q_target.gather(-1, best.unsqueeze(-1)).squeeze(-1)
    discount = torch.pow(torch.full_like(reward, gamma), duration.to(reward.dtype))
    return reward + discount * bootstrap * (~terminated).to(reward.dtype)


# ---------------------------------------------------------------------------- the update
def _obs(batch: dict[str, Tensor], prefix: str = "") -> ObsBatch:
    return ObsBatch(batch[f"{prefix}vectors"], batch.get(f"{prefix}images"))


class MacDQN:
    """Online and target Q-networks, Adam, and the conditional double-Q update."""

    def __init__(self, q: JointQNetwork, config: MacDQNConfig, *, gamma: float = 0.99) -> None:
        self.config = config
        self.gamma = gamma
        self.option_counts = q.option_counts
        self.q = q
        self.target = copy.deepcopy(q)
        self.target.requires_grad_(False)
        self.device = next(q.parameters()).device
        """Where the networks are: sampled batches come from the (CPU, numpy) replay to here."""
        self.optimizer = Adam(self.q.parameters(), lr=config.lr)

    def sync_target(self) -> None:
        self.target.load_state_dict(self.q.state_dict())

    def update(self, replay: SqueezedReplay, generator: torch.Generator) -> dict[str, float]:
        """One gradient step on a sampled batch; returns the TD loss and the mean chosen Q.
        A non-finite loss, gradient or weight stops it
        (:class:`~maopg.learner.base.NonFiniteError`)."""
        cfg = self.config
        if self.q.recurrent:
            q_taken, target = self._sequence_values(
                self._to_device(replay.sample_episodes(cfg.batch_episodes, generator))
            )
        else:
            batch = self._to_device(replay.sample(cfg.batch_size, generator))
            q_taken = self._taken(self.q(_obs(batch)), batch["joint"])
            with torch.no_grad():
                target = self._target(
                    batch, self.q(_obs(batch, "next_")), self.target(_obs(batch, "next_"))
                )
        loss = nn.functional.huber_loss(q_taken, target, delta=cfg.huber_delta)
        require_finite(loss, "the TD loss")
        self.optimizer.zero_grad()
        loss.backward()
        norm = nn.utils.clip_grad_norm_(self.q.parameters(), cfg.max_grad_norm)
        require_finite(norm, "the Q-network's gradient norm")
        self.optimizer.step()
        require_finite_parameters(self.q, "the Q-network")
        return {"loss": float(loss.detach()), "q_mean": float(q_taken.detach().mean())}

    def _to_device(self, batch: dict[str, Tensor]) -> dict[str, Tensor]:
        return {key: value.to(self.device) for key, value in batch.items()}

    def _taken(self, q: Tensor, joint: Tensor) -> Tensor:
        flat = ravel_joint(joint, self.option_counts)
        return q.gather(-1, flat.unsqueeze(-1)).squeeze(-1)

    def _target(self, batch: dict[str, Tensor], next_online: Tensor, next_target: Tensor) -> Tensor:
        return double_q_target(
            reward=batch["reward"] * self.config.reward_scale,
            duration=batch["duration"],
            terminated=batch["terminated"],
            next_q_online=next_online,
            next_q_target=next_target,
            next_choosing=batch["next_choosing"],
            next_running=batch["next_running"],
            next_available=batch["next_available"],
            option_counts=self.option_counts,
            gamma=self.gamma,
        )

    def _sequence_values(self, seq: dict[str, Tensor]) -> tuple[Tensor, Tensor]:
        """Chosen Q and targets of the real transitions of padded episodes.

        The GRU reads the episode's points ``z_0 .. z_T`` (``z_{t+1}`` is transition t's next
        observation) in one pass, so ``Q(z_t)`` and ``Q(z_{t+1})`` share the history.
        """
        mask = seq["mask"]
        batch, length = mask.shape
        # Within an episode transition t's next point is the point of t+1, so z_0 followed by
        # every transition's next observation is the whole sequence (padding repeats the last).
        inputs = {
            key: torch.cat([seq[key][:, :1], seq[f"next_{key}"]], dim=1)
            for key in ("vectors", "images")
            if key in seq
        }
        flat = ObsBatch(
            inputs["vectors"].flatten(0, 1),
            inputs["images"].flatten(0, 1) if "images" in inputs else None,
        )
        q_all = self.q.sequence(flat, batch, length + 1)
        q_taken = self._taken(q_all[:, :-1][mask], seq["joint"][mask])
        with torch.no_grad():
            target_all = self.target.sequence(flat, batch, length + 1)
            rows = {k: v[mask] for k, v in seq.items() if k != "mask"}
            target = self._target(rows, q_all[:, 1:][mask].detach(), target_all[:, 1:][mask])
        return q_taken, target

    # ------------------------------------------------------------------ checkpointing
    def state_dict(self) -> dict[str, Any]:
        return {
            "q": self.q.state_dict(),
            "target": self.target.state_dict(),
            "optimizer": self.optimizer.state_dict(),
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.q.load_state_dict(state["q"])
        self.target.load_state_dict(state["target"])
        self.optimizer.load_state_dict(state["optimizer"])


# ---------------------------------------------------------------------------- the learner
class MacDQNLearner(Learner):
    """Mac-DQN's collection loop: step the environments with the ε-greedy conditional argmax,
    storing every decision point in the squeezed replay; a gradient step falls due every
    ``dqn.train_every`` ticks from ``dqn.learning_starts`` on and the target network syncs every
    ``dqn.target_update_every`` ticks, so the x-axis (samples = ticks) means the same as for
    MAPPO."""

    Config = MacDQNConfig
    section = "dqn"
    columns: ClassVar[tuple[str, ...]] = ("loss", "q_mean", "epsilon", "updates")
    """``loss``/``q_mean`` average the iteration's gradient steps (NaN if none), ``epsilon`` is
    the exploration rate at the iteration's end, ``updates`` the number of gradient steps so
    far."""
    policy_key = "q"
    sampled_name = "ε-greedy"

    def __init__(self, policy: JointQNetwork, setup: LearnerSetup) -> None:
        super().__init__(policy, setup)
        self.dqn = MacDQN(policy, self.config, gamma=setup.gamma)
        self.replay = SqueezedReplay(setup.spec, self.config.buffer_size, setup.num_envs)
        self.gru_state = policy.initial_state(setup.num_envs)
        self.counters = {"slots": 0, "updates": 0, "syncs": 0}
        """Update slots passed, gradient steps taken, target syncs done."""

    def iteration(self, envs: SeededVectorEnv, samples: int) -> tuple[dict[str, Any], int]:
        dqn = self.config
        ticks, option_steps, rewards = 0, 0, []
        episodes: list[dict[str, Any]] = []
        stats: list[dict[str, float]] = []
        while ticks < self.setup.batch_ticks:
            points = envs.points
            with torch.no_grad():
                q, self.gru_state = self.policy.step(
                    ObsBatch.from_decision_points(points).to(self.device), self.gru_state
                )
                joint = epsilon_greedy(
                    q,
                    *(t.to(self.device) for t in stack_conditions(points)),
                    self.policy.option_counts,
                    dqn.epsilon(samples + ticks),
                    self.setup.sample_gen,
                )
            joints = joint.cpu().numpy()
            results = envs.step(joints)
            for e, result in enumerate(results):
                outcome = result.outcome
                self.replay.add(e, point_arrays(points[e]), joints[e], outcome)
                rewards.append(outcome.reward)
                if result.final is not None:
                    episodes.append(dict(outcome.info["episode"]))
                    if self.gru_state is not None:
                        self.gru_state[:, e] = 0.0
            option_steps += len(results)
            ticks += sum(r.outcome.duration for r in results)
            stats += self._due_updates(samples + ticks)
        row = {
            "option_steps": option_steps,
            **episode_metrics(episodes),
            "option_step_reward": mean(rewards),
            "loss": mean([s["loss"] for s in stats]),
            "q_mean": mean([s["q_mean"] for s in stats]),
            "epsilon": dqn.epsilon(samples + ticks),
            "updates": self.counters["updates"],
        }
        return row, ticks

    def _due_updates(self, samples: int) -> list[dict[str, float]]:
        """Run the gradient steps and target syncs that the tick count has made due.

        Steps due while the replay cannot yet serve a batch (no finished episode) are skipped,
        not deferred.
        """
        dqn, counters = self.config, self.counters
        stats = []
        if samples >= dqn.learning_starts:
            due = (samples - dqn.learning_starts) // dqn.train_every + 1
            ready = bool(self.replay.episodes) if dqn.recurrent else len(self.replay) > 0
            while counters["slots"] < due:
                if ready:
                    stats.append(self.dqn.update(self.replay, self.setup.update_gen))
                    counters["updates"] += 1
                counters["slots"] += 1
        syncs = samples // dqn.target_update_every
        if syncs > counters["syncs"]:
            self.dqn.sync_target()
            counters["syncs"] = syncs
        return stats

    def state_dict(self) -> dict[str, Any]:
        return {
            **self.dqn.state_dict(),
            "replay": self.replay.state_dict(),
            "counters": dict(self.counters),
            "gru_state": torch.empty(0) if self.gru_state is None else self.gru_state,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.dqn.load_state_dict(state)
        self.replay.load_state_dict(state["replay"])
        self.counters.update(state["counters"])
        if self.gru_state is not None:
            self.gru_state = state["gru_state"].to(self.device)

    @staticmethod
    def actor(policy: JointQNetwork, config: MacDQNConfig, *, greedy: bool, seed: int) -> Actor:
        """The conditional argmax; sampled, ε-greedy at the final exploration rate."""
        return QActor(policy, epsilon=0.0 if greedy else config.eps_end, seed=seed)


def joint_q_network(
    spec: EnvSpec, *, hidden: int, layers: int, config: MacDQNConfig, target: BuildTarget
) -> JointQNetwork:
    """Mac-DQN's acting network (the method registry's policy builder); a team whose joint
    option set cannot fit is refused before anything is allocated
    (:mod:`maopg.policy.joint_size`)."""
    # One update holds Q online, Q online and Q target of the next points for every row.
    rows = 3 * (config.batch_episodes * spec.max_ticks if config.recurrent else config.batch_size)
    require_joint_head_fits(
        spec.option_counts,
        hidden=hidden,
        copies=5,  # weights, gradient, Adam's two moments, the target network
        rows=rows,
        who="mac-dqn's Q-network",
        instead="Mac-DQN's centralized Q grows as ΠK_i and cannot scale; use async-ar",
        target=target,
    )
    return JointQNetwork(spec, hidden=hidden, layers=layers, recurrent=config.recurrent)

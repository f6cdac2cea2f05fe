"""Mac-IAICC (Xiao, Tan, Amato, NeurIPS 2022) and the siblings that share its code: asynchronous
macro-action actor-critics with one actor per agent, trained on each agent's own macro-action
trajectory.

- **Actors** (:class:`~maopg.policy.agent_centric.AgentCentricPolicy` without ACAC's time
  embedding and LayerNorm): per agent, Linear → leaky ReLU ×2, a GRU cell advanced at the
  agent's own decisions, Linear → leaky ReLU, the options' logits; no parameter sharing.
- **Critics**, by ``maciaicc.critic``:

  - ``history`` — **Mac-IAICC**: one *individual centralized* critic per agent, a GRU over the
    joint observation advanced at every decision point of the team, read at the agent's own;
  - ``state`` — **Mac-IAICC as MacroMARL's Box Pushing scripts run it** (their ``MacIAISC``):
    one critic per agent of the task's global state at the agent's own decision points, an
    MLP (:class:`StateCritics`), for the tasks that report a state (the Box Pushing tasks);
  - ``own`` — **Mac-IAC**: one critic per agent over its own observations only;
  - ``joint`` — **Naive Mac-IACC**: one centralized critic, trained on the team's decision
    points; an agent's advantage for a macro-action is the team's advantage of the last joint
    step inside it (the "naive" part: it ignores the rest of the agent's macro-action).

- **Targets** (``history``, ``own``): over agent i's macro-action k from its decision point
  ``t_k`` to its next one (or the episode's final point), ``R_k = Σ γ^j r`` over its ticks and
  ``y_k = R_k + γ^{τ_k} V̄_i(h_{t_{k+1}})`` with ``τ_k`` its ticks (0 after a terminal state;
  a timeout bootstraps), from a target copy of the critics refreshed every ``target_every``
  episodes; with ``n_step`` = n, the rewards of n macro-actions before the bootstrap
  (:func:`n_step_targets`; the Naive critic's over the team's steps). One critic step on the
  squared error, then ``A_k = y_k − V_i(h_{t_k})`` from the stepped critic, then one actor
  step on ``−γ^{e_k} log μ_i(a_k) A_k`` averaged over the agent's decisions (``e_k``: the
  index of its last tick; ``μ``: the ε-mixed policy, as collected). No entropy bonus,
  advantage normalisation or gradient clipping.
- **Collection**: whole episodes in rounds (:func:`~maopg.learner.rounds.collect_round`), ε
  falling linearly over ``explore_decay`` episodes.

The fourth sibling of the paper, **Mac-CAC**, does not come out of this code: its one actor is
centralized, choosing the joint macro-action of the agents whose macro-actions ended from the
joint history, with a centralized critic. That is the family of the paper maopg reproduces
(``async`` and its recurrent and factored forms, trained by PPO), so it is not registered
again here.

From the authors' public code (MacroMARL), where the paper leaves a choice: the sizes
(32-wide, critics Linear ×2 and a GRU), the γ^{e_k} weight of the policy gradient, critic and
actor learning rates (3e-3, 3e-4) and their Box Pushing rounds (32 episodes, 32 environments,
target every 128 episodes on 6x6, ε over 4,000 episodes). Its Box Pushing scripts run the
state-reading critics (``critic=state``); the default reads the joint observation history as
the paper describes, so it runs on every task. Every decision is trained on, one whose option
the episode's end cut short included (that code drops those).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import torch
from torch import Tensor, nn

from maopg.env.contract import EnvSpec
from maopg.learner.base import (
    LearnerSetup,
)
from maopg.learner.rounds import Episodes, RoundsLearner
from maopg.learner.sections import MacIAICCConfig
from maopg.policy import ObsBatch
from maopg.policy.agent_centric import AgentCentricPolicy, AgentInput, leaky_mlp, linear, scan
from maopg.policy.batch import vector_slices
from maopg.policy.encoders import NatureCNN
from maopg.policy.joint_size import BuildTarget


class JointInput(nn.Module):
    """The joint observation (every agent's vector, and camera through one CNN) → features."""

    def __init__(self, spec: EnvSpec, width: int, cnn_features: int = 256) -> None:
        super().__init__()
        self.cnn = NatureCNN.of_spec(spec, cnn_features) if spec.image_shape is not None else None
        in_dim = vector_slices(spec)[-1].stop
        in_dim += spec.num_agents * cnn_features if self.cnn is not None else 0
        self.mlp = leaky_mlp(in_dim, width)

    def forward(self, obs: ObsBatch) -> Tensor:
        parts = [obs.vectors]
        if self.cnn is not None:
            images = obs.dense_images()
            if images is None:
                raise ValueError("this network reads images but the batch has none")
            parts.append(self.cnn(images.flatten(0, 1)).view(len(images), -1))
        return self.mlp(torch.cat(parts, dim=-1))


class HistoryCritics(nn.Module):
    """``heads`` recurrent critics: each its own input network, GRU cell and value head. A critic
    reading the joint observation advances at every decision point of the team; one reading
    its agent's own (``own``) only where that agent chooses."""

    def __init__(self, spec: EnvSpec, kind: str, width: int) -> None:
        super().__init__()
        self.kind = kind
        count = 1 if kind == "joint" else spec.num_agents
        self.inputs = nn.ModuleList(
            AgentInput(spec, i, width, 256, embed_time=False)
            if kind == "own"
            else JointInput(spec, width)
            for i in range(count)
        )
        self.cells = nn.ModuleList(nn.GRUCell(width, width) for _ in range(count))
        self.heads = nn.ModuleList(linear(width, 1, 1.0) for _ in range(count))
        self.width = width

    def values(self, batch: Episodes, device: torch.device) -> Tensor:
        """``[T, B, heads]`` values along the batch's points (the final point included)."""
        obs = batch.obs.to(device)
        steps, episodes = batch.choosing.shape[:2]
        advancing = batch.choosing.to(device)
        if self.kind != "own":  # the team's history: every point of it
            advancing = torch.ones(steps, episodes, len(self.cells), dtype=torch.bool)
        states = scan(
            self.cells,
            [net(obs) for net in self.inputs],
            advancing.to(device),
            batch.starts.to(device),
            torch.zeros(episodes, len(self.cells), self.width, device=device),
        )
        return torch.stack([head(states[:, :, i]) for i, head in enumerate(self.heads)], 2)[..., 0]


class StateCritics(nn.Module):
    """One critic per agent of the task's global state: four leaky-ReLU layers ``width`` wide
    (two in, then two where the history critics have their GRU) and a value head, as
    MacroMARL's state-based critics. A state needs no memory, so each is read at any point."""

    def __init__(self, spec: EnvSpec, width: int) -> None:
        super().__init__()
        if spec.state_size is None:
            raise ValueError(f"task {spec.task!r} reports no global state for these critics")
        self.nets = nn.ModuleList(
            nn.Sequential(
                leaky_mlp(spec.state_size, width),
                leaky_mlp(width, width),
                linear(width, 1, 1.0),
            )
            for _ in range(spec.num_agents)
        )

    def values(self, batch: Episodes, device: torch.device) -> Tensor:
        """``[T, B, agents]`` values along the batch's points (the final point included)."""
        states = batch.obs.states
        if states is None:
            raise ValueError("these critics read the global state but the batch has none")
        states = states.to(device)
        steps, episodes = batch.choosing.shape[:2]
        return torch.cat([net(states) for net in self.nets], dim=-1).view(steps, episodes, -1)


@dataclass
class MacroSteps:
    """Each agent's macro-actions in a batch: row ``t`` and episode ``b`` where it chose, the row
    it next chose at (or the final point), their discounted reward, discount to the next value,
    terminal flag and the weight ``γ^{e}`` of the policy gradient. ``team_row`` is the last
    team decision point inside the macro-action (Naive Mac-IACC's advantage)."""

    rows: np.ndarray
    episodes: np.ndarray
    next_rows: np.ndarray
    team_rows: np.ndarray
    reward: np.ndarray
    discount: np.ndarray
    terminal: np.ndarray
    weight: np.ndarray


def n_step_targets(
    reward: np.ndarray,
    discount: np.ndarray,
    bootstrap: np.ndarray,
    episode: np.ndarray,
    n: int,
) -> np.ndarray:
    """``y_k = Σ_{m<n} (Π_{l<m} d_{k+l}) R_{k+m} + (Π_{l<n} d_{k+l}) V_{k+n}`` over consecutive
    steps ``k`` of one sequence per episode (steps listed episode by episode, in order):
    ``reward`` ``R``, ``discount`` ``d`` (γ to the step's ticks) and ``bootstrap`` ``V`` (the
    target value where the step ends, 0 after a terminal state). The sum stops early at the
    episode's last step and bootstraps there; ``n = 1`` is the one-step target."""
    targets = np.empty(len(reward))
    for k in range(len(reward)):
        total, scale, j = 0.0, 1.0, k
        for m in range(n):
            total += scale * reward[j]
            scale *= discount[j]
            if m == n - 1 or j + 1 == len(reward) or episode[j + 1] != episode[k]:
                break
            j += 1
        targets[k] = total + scale * bootstrap[j]
    return targets


def macro_steps(batch: Episodes, agent: int, gamma: float) -> MacroSteps:
    """Agent ``agent``'s macro-actions in ``batch`` (:class:`MacroSteps`)."""
    ticks = batch.obs.ticks
    assert ticks is not None
    ticks = ticks.view(batch.choosing.shape[:2]).numpy()
    found: list[tuple] = []
    for b, length in enumerate(batch.length):
        chose = [t for t in range(length) if batch.choosing[t, b, agent]]
        for k, t in enumerate(chose):
            nxt = chose[k + 1] if k + 1 < len(chose) else int(length)
            offsets = ticks[t:nxt, b] - ticks[t, b]
            reward = float((gamma**offsets * batch.reward[t:nxt, b]).sum())
            elapsed = int(ticks[nxt, b] - ticks[t, b])
            terminal = nxt == length and bool(batch.terminated[b])
            weight = gamma ** (int(ticks[nxt, b]) - 1)
            found.append((t, b, nxt, nxt - 1, reward, gamma**elapsed, terminal, weight))
    columns = list(zip(*found, strict=True)) if found else [()] * 8
    return MacroSteps(*(np.array(c) for c in columns))


class MacIAICCLearner(RoundsLearner):
    """Mac-IAICC and its siblings (module docstring)."""

    Config = MacIAICCConfig
    section = "maciaicc"
    columns: ClassVar[tuple[str, ...]] = (
        "policy_loss",
        "value_loss",
        "entropy",
        "epsilon",
        "published_steps",
    )
    """``entropy``: the policy's own (unmixed), summed over the choosing agents of a decision
    point; ``published_steps``: the summed length of the finished training episodes so far."""

    def __init__(self, policy: AgentCentricPolicy, setup: LearnerSetup) -> None:
        cfg: MacIAICCConfig = setup.config
        critics: nn.Module = (
            StateCritics(setup.spec, cfg.width)
            if cfg.critic == "state"
            else HistoryCritics(setup.spec, cfg.critic, cfg.width)
        )
        super().__init__(policy, setup, critics)

    def _targets(self, batch: Episodes, agent_steps: list[MacroSteps]) -> list[Tensor]:
        """Each agent's ``y_k`` (or, ``joint``, the team's ``y`` per point) from the target."""
        with torch.no_grad():
            values = self.target.values(batch, self.device).cpu().numpy()
        gamma, n = self.setup.gamma, self.config.n_step
        if self.config.critic == "joint":
            steps = batch.steps.numpy()
            following = np.concatenate([values[1:, :, 0], np.zeros_like(values[:1, :, 0])])
            last = np.zeros_like(steps)
            last[batch.length - 1, np.arange(len(batch.length))] = True
            ended = last & batch.terminated[None, :]
            points = np.nonzero(steps.T)  # (episode, point), episode by episode
            team = np.zeros(steps.shape)
            team[points[1], points[0]] = n_step_targets(
                batch.reward.T[points],
                (gamma**batch.duration).T[points],
                np.where(ended, 0.0, following).T[points],
                points[0],
                n,
            )
            return [torch.as_tensor(team, dtype=torch.float32)]
        return [
            torch.as_tensor(
                n_step_targets(
                    s.reward,
                    s.discount,
                    np.where(s.terminal, 0.0, values[s.next_rows, s.episodes, i]),
                    s.episodes,
                    n,
                ),
                dtype=torch.float32,
            )
            for i, s in enumerate(agent_steps)
        ]

    def update(self, batch: Episodes, epsilon: float) -> dict[str, float]:
        """One critic step, then one step of each actor (module docstring)."""
        device, joint = self.device, self.config.critic == "joint"
        agent_steps = [macro_steps(batch, i, self.setup.gamma) for i in range(len(self.actor_opts))]
        targets = [y.to(device) for y in self._targets(batch, agent_steps)]
        values = self.critic.values(batch, device)
        if joint:
            steps = batch.steps.to(device)
            errors = (targets[0] - values[..., 0])[steps]
        else:
            errors = torch.cat(
                [
                    targets[i] - values[s.rows, s.episodes, i]
                    for i, s in enumerate(agent_steps)
                    if len(s.rows)
                ]
            )
        value_loss = errors.square().mean()
        self.step_critic(value_loss)
        with torch.no_grad():
            stepped = self.critic.values(batch, device)
        log_probs, entropy = self.agent_log_probs(batch, epsilon)
        losses = {}
        for i, s in enumerate(agent_steps):
            if not len(s.rows):
                continue
            if joint:
                advantage = (targets[0] - stepped[..., 0])[s.team_rows, s.episodes]
            else:
                advantage = targets[i] - stepped[s.rows, s.episodes, i]
            weight = torch.as_tensor(s.weight, dtype=torch.float32, device=device)
            chosen = log_probs[i][s.rows, s.episodes]
            losses[i] = -(weight * chosen * advantage).mean()
        self.step_actors(losses)
        self.require_finite_networks()
        return {
            "policy_loss": float(np.mean([loss.item() for loss in losses.values()])),
            "value_loss": value_loss.item(),
            "entropy": entropy[batch.steps.to(device)].mean().item(),
        }


def macro_actors(
    spec: EnvSpec, *, hidden: int, layers: int, config: MacIAICCConfig, target: BuildTarget
) -> AgentCentricPolicy:
    """The MacroMARL actors at ``maciaicc.width`` (the run's ``hidden``/``layers`` size maopg's
    own networks)."""
    del hidden, layers, target
    return AgentCentricPolicy(spec, width=config.width, embed_time=False, head_norm=False)

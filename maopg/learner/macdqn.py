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

Hyper-parameters (:class:`MacDQNConfig`) name their source: the MacDeepMARL Tool Delivery command
(``ma_cen_condi_ddrqn.py --env_name=OSD_S_4 ...``) and its code defaults where they carry over,
"chosen here" where our setting differs (budgets in ticks instead of episodes, Huber loss and
gradient clipping that the original leaves off by default).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.policy import (
    JointEncoder,
    ObsBatch,
    init_orthogonal,
    joint_slice_mask,
    ravel_joint,
    unravel_joint,
)


@dataclass(frozen=True)
class MacDQNConfig:
    """Mac-DQN's own hyper-parameters (the ``dqn`` section of ``train``'s config). Durations are
    in low-level ticks (samples), as everywhere here.

    The discount and the network size are not here: they are the run's ``gamma`` (which also
    discounts the environment's rewards, so the two cannot disagree), ``hidden`` and ``layers``,
    shared with MAPPO so both methods optimise the same objective with the same encoders
    (docs/DESIGN.md §5; MacDeepMARL's TD command used ``--rnn_h_size=128`` too, and γ = 1.0 per
    macro-step where we use 0.99 per tick).
    """

    lr: float = 6e-4
    """Adam step size: MacDeepMARL TD command ``--l_rate=0.0006``."""
    batch_size: int = 64
    """Transitions per update (feed-forward). Chosen here (the original samples whole episodes)."""
    batch_episodes: int = 16
    """Episodes per update (recurrent): MacDeepMARL TD command ``--batch_size=16 --sample_epi``."""
    buffer_size: int = 50_000
    """Decision-point transitions kept. The original kept 1,000 episodes
    (``--replay_buffer_size=1000``), about 30-60K decision points on Tool Delivery."""
    learning_starts: int = 1_000
    """Ticks collected before the first update. Chosen here (original: 2 episodes, ~300 ticks)."""
    train_every: int = 5
    """Ticks between updates. Chosen here to keep MacDeepMARL's replay ratio: its TD command
    (``--train_freq=30 --batch_size=16 --sample_epi``) replays 16 episodes of ~40 decision
    points every 30 ticks (~20 transitions per tick); 64 rows every 5 ticks is ~13. With
    ``recurrent`` (16 whole episodes per update) use the original 30."""
    target_update_every: int = 1_000
    """Ticks between target-network syncs. Chosen here: MacDeepMARL's default
    ``--target_update_freq=5000`` spans ~170 of its updates; 1,000 ticks spans 200 of ours."""
    eps_start: float = 1.0
    """MacDeepMARL ``EPS_START``."""
    eps_end: float = 0.1
    """MacDeepMARL ``EPS_END``."""
    eps_decay: int = 15_000
    """Ticks of the linear ε decay. Chosen here: the original decays over 6,000 *episodes*
    (``--eps_l_d_steps=6000``, ~0.5-0.9M ticks), far beyond our budgets."""
    huber_delta: float = 10.0
    """Huber TD loss. Chosen here (original: squared error unless ``--huber_l``); δ as MAPPO's
    value loss (docs/DESIGN.md §5), so ±100 delivery rewards do not dominate the gradient."""
    max_grad_norm: float = 10.0
    """Gradient-norm clip. Chosen here (original: off unless ``--g_clip_norm``), as MAPPO."""
    reward_scale: float = 1.0
    """Factor on every reward the Q-network learns from, so Q-values (and ``q_mean`` in the log)
    are in scaled units; the greedy option is unchanged by a positive factor. ``huber_delta``
    and ``max_grad_norm`` were chosen for Tool Delivery's ±100 rewards: Water Filling's are
    ~-10³ per tick, where ``1e-3`` brings them to the same scale (results/README.md, finding 5).
    MAPPO needs no such factor: its value normalisation rescales the returns."""
    recurrent: bool = False
    """GRU over the option-level history (the original used an LSTM over squeezed episodes).
    Off by default: the joint observation of Tool Delivery is nearly Markov and the feed-forward
    net is several times cheaper on 2 cores."""

    def epsilon(self, samples: int) -> float:
        """Linear ε schedule over ticks (MacDeepMARL ``Linear_Decay``)."""
        frac = min(1.0, samples / self.eps_decay) if self.eps_decay > 0 else 1.0
        return self.eps_start + frac * (self.eps_end - self.eps_start)

    def validate(self) -> None:
        for key in ("batch_size", "batch_episodes", "buffer_size", "train_every"):
            if getattr(self, key) < 1:
                raise ValueError(f"{key} must be >= 1, got {getattr(self, key)}")
        if not 0.0 <= self.eps_end <= 1.0 or not 0.0 <= self.eps_start <= 1.0:
            raise ValueError("epsilon values must lie in [0, 1]")
        if not (math.isfinite(self.reward_scale) and self.reward_scale > 0.0):
            raise ValueError(f"reward_scale must be a positive number, got {self.reward_scale}")


# ---------------------------------------------------------------------------- network
class JointQNetwork(nn.Module):
    """``Q(z, ·)`` over the flattened joint option: joint encoder (+ GRU) + linear head.

    Feed-forward: :meth:`forward` maps ``B`` observations to ``[B, ΠK_i]``. Recurrent: the GRU
    runs over one episode's decision points in order; :meth:`step` advances it by one point
    while acting, :meth:`sequence` runs whole padded episodes for training.
    """

    def __init__(
        self,
        spec: EnvSpec,
        hidden: int = 128,
        layers: int = 2,
        recurrent: bool = False,
        use_images: bool | None = None,
    ) -> None:
        super().__init__()
        self.option_counts = spec.option_counts
        self.encoder = JointEncoder(spec, hidden=hidden, layers=layers, use_images=use_images)
        self.gru = nn.GRU(hidden, hidden, batch_first=True) if recurrent else None
        self.head = nn.Linear(hidden, math.prod(self.option_counts))
        init_orthogonal(self.head, 1.0)

    @property
    def recurrent(self) -> bool:
        return self.gru is not None

    def initial_state(self, batch: int) -> Tensor | None:
        """Zero GRU state for ``batch`` fresh episodes (``None`` when feed-forward)."""
        if self.gru is None:
            return None
        return torch.zeros(1, batch, self.gru.hidden_size)

    def forward(self, obs: ObsBatch) -> Tensor:
        if self.gru is not None:
            raise RuntimeError("the recurrent Q-network needs step() or sequence()")
        return self.head(self.encoder(obs))

    def step(self, obs: ObsBatch, state: Tensor | None) -> tuple[Tensor, Tensor | None]:
        """Q of one decision point per row, and the advanced GRU state."""
        if self.gru is None:
            return self.forward(obs), None
        out, state = self.gru(self.encoder(obs).unsqueeze(1), state)
        return self.head(out.squeeze(1)), state

    def sequence(self, obs: ObsBatch, batch: int, length: int) -> Tensor:
        """``[B, T, ΠK]`` for ``obs`` holding ``B`` episodes of ``T`` points, row-major, from zero
        state. Padding after an episode's end does not affect its earlier outputs (causal)."""
        features = self.encoder(obs).view(batch, length, -1)
        if self.gru is not None:
            features, _ = self.gru(features)
        return self.head(features)


# ---------------------------------------------------------------------------- target and acting
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
    explore = torch.rand(choosing.shape, generator=generator) < epsilon
    for i, mask in enumerate(masks):
        # Rows whose agent i is not choosing may have an all-false mask: give multinomial
        # something valid there; the pick is discarded by the where below.
        weights = torch.where(choosing[:, i : i + 1], mask, True).float()
        random = torch.multinomial(weights, 1, generator=generator).squeeze(-1)
        joint[:, i] = torch.where(explore[:, i] & choosing[:, i], random, joint[:, i])
    return torch.where(choosing, joint, running)


# ---------------------------------------------------------------------------- replay
def _obs_fields(spec: EnvSpec) -> dict[str, tuple[tuple[int, ...], Any]]:
    """Shape and dtype of one point's stored arrays (observation + conditional)."""
    n = spec.num_agents
    fields: dict[str, tuple[tuple[int, ...], Any]] = {
        "vectors": ((sum(a.vector_size for a in spec.agents),), np.float32),
        "choosing": ((n,), np.bool_),
        "running": ((n,), np.int64),
        "available": ((sum(spec.option_counts),), np.bool_),
    }
    if spec.image_shape is not None:
        fields["images"] = ((n, *spec.image_shape), np.uint8)
    return fields


def point_arrays(point: DecisionPoint) -> dict[str, np.ndarray]:
    """Copies of what the replay stores of a decision point (the env reuses its buffers)."""
    arrays = {
        "vectors": np.concatenate(point.vectors).astype(np.float32),
        "choosing": np.asarray(point.choosing, dtype=np.bool_).copy(),
        "running": np.asarray(point.running, dtype=np.int64).copy(),
        "available": np.concatenate(point.available).astype(np.bool_),
    }
    if point.images is not None:
        arrays["images"] = np.array(point.images, dtype=np.uint8)
    return arrays


class SqueezedReplay:
    """Replay of decision-point transitions ("squeezed" experience, one row per option step).

    A row holds the point acted on (observation, ``U_t``, running options, availability), the
    joint option, the discounted reward over the ``k`` ticks, ``k``, the next point (its
    observation, ``U``, running options, availability) and ``terminated``.

    Each environment's transitions are held back until its episode ends and then written as one
    contiguous block of the ring, so whole episodes can be sampled for the recurrent Q-network;
    the feed-forward learner samples single rows uniformly. When the ring wraps, the oldest rows
    are overwritten and episodes that lost rows are no longer offered as sequences.
    """

    def __init__(self, spec: EnvSpec, capacity: int, num_envs: int) -> None:
        if capacity < spec.max_ticks:
            raise ValueError(f"capacity {capacity} cannot hold one episode ({spec.max_ticks})")
        self.capacity = capacity
        self.option_counts = spec.option_counts
        layout = _obs_fields(spec)
        n = spec.num_agents
        self.layout: dict[str, tuple[tuple[int, ...], Any]] = {
            **layout,
            "joint": ((n,), np.int64),
            "reward": ((), np.float32),
            "duration": ((), np.int64),
            "terminated": ((), np.bool_),
            **{f"next_{k}": v for k, v in layout.items()},
        }
        self.data = {
            k: np.zeros((capacity, *shape), dtype) for k, (shape, dtype) in self.layout.items()
        }
        self.total = 0
        """Rows ever written; row ``a`` lives in slot ``a % capacity``."""
        self.episodes: deque[tuple[int, int]] = deque()
        """``(first row, length)`` of the intact episodes in the ring, oldest first."""
        self.pending: list[list[dict[str, np.ndarray]]] = [[] for _ in range(num_envs)]

    def __len__(self) -> int:
        return min(self.total, self.capacity)

    def add(
        self,
        env: int,
        point: dict[str, np.ndarray],
        joint: np.ndarray,
        outcome: DecisionPoint,
    ) -> None:
        """Store env ``env``'s transition from ``point`` (see :func:`point_arrays`) taking
        ``joint``, whose result is ``outcome`` (the next point, or the episode's final one)."""
        if outcome.duration < 1:
            raise ValueError("a transition spans at least one tick")
        row = dict(point)
        row.update({f"next_{k}": v for k, v in point_arrays(outcome).items()})
        row["joint"] = np.asarray(joint, dtype=np.int64).copy()
        row["reward"] = np.float32(outcome.discounted_reward)
        row["duration"] = np.int64(outcome.duration)
        row["terminated"] = np.bool_(outcome.terminated)
        self.pending[env].append(row)
        if outcome.done:
            self._commit(self.pending[env])
            self.pending[env] = []

    def _commit(self, rows: list[dict[str, np.ndarray]]) -> None:
        if len(rows) > self.capacity:
            raise ValueError(f"an episode of {len(rows)} points exceeds the capacity")
        slots = (self.total + np.arange(len(rows))) % self.capacity
        for key, store in self.data.items():
            store[slots] = np.stack([r[key] for r in rows])
        self.episodes.append((self.total, len(rows)))
        self.total += len(rows)
        while self.episodes and self.episodes[0][0] < self.total - self.capacity:
            self.episodes.popleft()

    def _gather(self, rows: np.ndarray) -> dict[str, Tensor]:
        slots = rows % self.capacity
        return {k: torch.from_numpy(v[slots]) for k, v in self.data.items()}

    def sample(self, batch: int, generator: torch.Generator) -> dict[str, Tensor]:
        """``batch`` transitions drawn uniformly (with replacement) from the stored rows."""
        if len(self) == 0:
            raise ValueError("the replay is empty")
        offsets = torch.randint(len(self), (batch,), generator=generator).numpy()
        return self._gather(self.total - len(self) + offsets)

    def sample_episodes(self, batch: int, generator: torch.Generator) -> dict[str, Tensor]:
        """``batch`` whole episodes, padded to the longest: every entry ``[B, T, ...]``, plus
        ``mask`` ``bool [B, T]`` marking real transitions."""
        if not self.episodes:
            raise ValueError("no complete episode in the replay")
        picks = torch.randint(len(self.episodes), (batch,), generator=generator).tolist()
        spans = [self.episodes[p] for p in picks]
        length = max(n for _, n in spans)
        rows = np.array([[s + min(t, n - 1) for t in range(length)] for s, n in spans])
        out = self._gather(rows)
        lengths = torch.tensor([n for _, n in spans])
        out["mask"] = torch.arange(length).unsqueeze(0) < lengths.unsqueeze(1)
        return out

    # ------------------------------------------------------------------ checkpointing
    def state_dict(self) -> dict[str, Any]:
        return {
            "total": self.total,
            "data": {k: torch.from_numpy(v[: len(self)].copy()) for k, v in self.data.items()},
            "episodes": [list(e) for e in self.episodes],
            "pending": [
                {k: torch.from_numpy(np.stack([r[k] for r in rows])) for k in self.layout}
                if rows
                else {}
                for rows in self.pending
            ],
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if len(state["pending"]) != len(self.pending):
            raise ValueError("the saved replay was made for another number of environments")
        self.total = int(state["total"])
        for key, store in self.data.items():
            saved = state["data"][key].numpy()
            store[: len(saved)] = saved
        self.episodes = deque((int(s), int(n)) for s, n in state["episodes"])
        self.pending = [
            [{k: v[t].numpy() for k, v in rows.items()} for t in range(len(rows["joint"]))]
            if rows
            else []
            for rows in state["pending"]
        ]


# ---------------------------------------------------------------------------- learner
def _obs(batch: dict[str, Tensor], prefix: str = "") -> ObsBatch:
    return ObsBatch(batch[f"{prefix}vectors"], batch.get(f"{prefix}images"))


class MacDQN:
    """Online and target Q-networks, Adam, and the conditional double-Q update."""

    def __init__(
        self,
        spec: EnvSpec,
        config: MacDQNConfig,
        *,
        gamma: float = 0.99,
        hidden: int = 128,
        layers: int = 2,
        use_images: bool | None = None,
    ) -> None:
        config.validate()
        self.config = config
        self.gamma = gamma
        self.option_counts = spec.option_counts
        kw = {"hidden": hidden, "layers": layers, "use_images": use_images}
        self.q = JointQNetwork(spec, recurrent=config.recurrent, **kw)
        self.target = JointQNetwork(spec, recurrent=config.recurrent, **kw)
        self.target.load_state_dict(self.q.state_dict())
        self.target.requires_grad_(False)
        self.optimizer = torch.optim.Adam(self.q.parameters(), lr=config.lr)

    def sync_target(self) -> None:
        self.target.load_state_dict(self.q.state_dict())

    @torch.no_grad()
    def act(
        self,
        obs: ObsBatch,
        choosing: Tensor,
        running: Tensor,
        available: Tensor,
        state: Tensor | None,
        epsilon: float,
        generator: torch.Generator,
    ) -> tuple[Tensor, Tensor | None]:
        """ε-greedy joint options for one decision point per row, and the next GRU state."""
        q, state = self.q.step(obs, state)
        joint = epsilon_greedy(
            q, choosing, running, available, self.option_counts, epsilon, generator
        )
        return joint, state

    def update(self, replay: SqueezedReplay, generator: torch.Generator) -> dict[str, float]:
        """One gradient step on a sampled batch; returns the TD loss and the mean chosen Q."""
        cfg = self.config
        if self.q.recurrent:
            q_taken, target = self._sequence_values(
                replay.sample_episodes(cfg.batch_episodes, generator)
            )
        else:
            batch = replay.sample(cfg.batch_size, generator)
            q_taken = self._taken(self.q(_obs(batch)), batch["joint"])
            with torch.no_grad():
                target = self._target(
                    batch, self.q(_obs(batch, "next_")), self.target(_obs(batch, "next_"))
                )
        loss = nn.functional.huber_loss(q_taken, target, delta=cfg.huber_delta)
        self.optimizer.zero_grad()
        loss.backward()
        nn.utils.clip_grad_norm_(self.q.parameters(), cfg.max_grad_norm)
        self.optimizer.step()
        return {"loss": float(loss.detach()), "q_mean": float(q_taken.detach().mean())}

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

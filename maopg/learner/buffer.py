"""Rollout storage: option steps of ``E`` environments stepped in lockstep, as a ``[S, E]`` grid.

Row ``s`` holds, for every environment, the decision point ``z`` the policy acted on, the
condition (``choosing``, ``running``, ``available``), the sampled joint option with its
conditional log-probability, the critic's (normalised) value, and the outcome reported at the
next decision point: summed and discounted reward, duration ``k`` in ticks, terminated /
truncated. Because every environment takes one option step per row, the grid is regular even
though the rows cover different numbers of ticks in different environments.

:meth:`Rollout.training_batch` turns the grid into the flat :class:`TrainBatch` the PPO update
consumes (advantages by :func:`~maopg.learner.gae.compute_gae`). A recurrent learner's rows also
carry a :class:`Memory` (episode starts and the GRU states carried into the points), from which
:meth:`TrainBatch.chunks` training chunks restart.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from torch import Tensor

from maopg.learner.gae import DiscountForm, compute_gae
from maopg.learner.value_norm import ValueNorm
from maopg.policy import ObsBatch


@dataclass
class TrainBatch:
    """Flat decision-point samples for one PPO update (rows = option steps)."""

    obs: ObsBatch
    choosing: Tensor
    """``bool [B, N]``."""
    running: Tensor
    """``int64 [B, N]``."""
    available: Tensor
    """``bool [B, ΣK_i]``."""
    joint: Tensor
    """``int64 [B, N]`` the joint option executed (``running`` for continuing agents)."""
    old_log_prob: Tensor
    """``float32 [B]`` conditional log-probability at sampling time."""
    old_value: Tensor
    """``float32 [B]`` critic output at sampling time (normalised space when value-norm is on)."""
    returns: Tensor
    """``float32 [B]`` value targets ``A + V`` in return units."""
    advantages: Tensor
    """``float32 [B]`` GAE advantages (not yet normalised)."""
    num_envs: int = 1
    """``E``: row ``s * E + e`` is option step ``s`` of environment ``e``."""
    epsilon: Tensor | None = None
    """``float32 [B]`` the exploration mixed into the behaviour that chose, whose probabilities
    ``old_log_prob`` are (PPO scores the updated policy mixed alike); ``None``: none."""
    starts: Tensor | None = None
    """Recurrent only: ``bool [B]`` the point opens an episode (the memory restarts there)."""
    policy_state: Tensor | None = None
    """Recurrent only: ``[B, S, H]`` the policy's state carried into the point at collection."""
    critic_state: Tensor | None = None
    """Recurrent only: ``[B, 1, H]`` the critic's state carried into the point."""

    def __len__(self) -> int:
        return self.old_log_prob.shape[0]

    def to(self, device: torch.device | str) -> TrainBatch:
        """The batch on ``device`` (the bank and ``image_index`` of banked images included)."""
        return dataclasses.replace(
            self,
            obs=self.obs.to(device),
            **{name: value.to(device) for name, value in self._tensors().items()},
        )

    def rows(self, index: Tensor) -> TrainBatch:
        """The minibatch ``index`` (a 1-D index tensor)."""
        return dataclasses.replace(
            self,
            obs=self.obs[index],
            **{name: value[index] for name, value in self._tensors().items()},
        )

    def _tensors(self) -> dict[str, Tensor]:
        """Every per-row tensor but the observations (the recurrent ones where present)."""
        return {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if f.name not in ("obs", "num_envs") and getattr(self, f.name) is not None
        }

    def chunks(self, length: int) -> Tensor:
        """``int64 [C, L]``: the rows of each chunk of up to ``length`` consecutive option steps
        of one environment, ``-1`` after a chunk cut short by the end of the rollout.

        Chunks are cut at fixed positions (every ``length`` rows from the rollout's first), not
        at episode ends: a reset inside a chunk is masked by :attr:`starts`, as in rMAPPO, so
        every chunk but an environment's last is full. ``L`` is ``min(length, steps)``.
        """
        steps = len(self) // self.num_envs
        length = min(length, steps)
        starts = torch.arange(0, steps, length)
        offsets = torch.arange(length)
        step = starts.view(-1, 1) + offsets  # [chunks per env, L]
        envs = torch.arange(self.num_envs).view(-1, 1, 1)
        rows = torch.where(step < steps, step * self.num_envs + envs, -1)
        return rows.reshape(-1, length).to(self.old_log_prob.device)


@dataclass(frozen=True)
class Memory:
    """What a recurrent learner keeps of one row beside the option step: which points open an
    episode ``bool [E]``, and the policy's and critic's states carried into them (CPU)."""

    starts: Tensor
    policy_state: Tensor
    critic_state: Tensor


@dataclass
class Rollout:
    """A ``[S, E]`` grid of option steps, filled row by row by the collection loop.

    Camera images are stored once each: an agent's observation refreshes exactly when it
    chooses (the option contract, :mod:`maopg.env.contract`), so a row adds to the image bank
    only the cameras of its choosing agents (every camera on the first row) and points the
    others at the image they saw when they last chose. The training batch is banked
    (:class:`~maopg.policy.ObsBatch`), and the encoders run the CNN once per image.

    The grid lives on the CPU whatever the learner's device: it is filled one row per option
    step from numpy observations the (CPU) simulation produced, and GAE runs over it in numpy,
    so on a GPU every row would otherwise cross twice (there and back for GAE). Instead the
    whole training batch crosses once per iteration (:meth:`TrainBatch.to`), and the ``epochs
    x num_minibatches`` passes of the update index it on the device. The size of that copy:
    Tool Delivery's batch of ~200 ticks is a few hundred rows of ~100 floats (kilobytes);
    Water Filling's with cameras is dominated by the bank of distinct 64x64x3 ``uint8`` images
    (a few thousand: ~10-40 MB, milliseconds over PCIe, kept as bytes until the encoder).
    """

    num_envs: int
    epsilon: float = 0.0
    """The weight of the exploration mixed into the policy that collected the rollout."""
    vectors: list[Tensor] = field(default_factory=list)
    bank: list[Tensor] = field(default_factory=list)
    """Every distinct camera image of the rollout, ``[H, W, planes]`` each (the environment's
    dtype: uint8 for colour alone), in order seen."""
    image_index: list[Tensor] = field(default_factory=list)
    """Per row ``int64 [E, N]``: the bank entry each agent's camera showed."""
    choosing: list[Tensor] = field(default_factory=list)
    running: list[Tensor] = field(default_factory=list)
    available: list[Tensor] = field(default_factory=list)
    joint: list[Tensor] = field(default_factory=list)
    log_prob: list[Tensor] = field(default_factory=list)
    value: list[Tensor] = field(default_factory=list)
    """Critic outputs ``[E]`` per row, in the critic's (normalised) space."""
    next_value: list[Tensor] = field(default_factory=list)
    """``V(z_{t+1})`` ``[E]`` per row, critic space; filled in by the sampler after the step."""
    reward_sum: list[np.ndarray] = field(default_factory=list)
    reward_discounted: list[np.ndarray] = field(default_factory=list)
    duration: list[np.ndarray] = field(default_factory=list)
    terminated: list[np.ndarray] = field(default_factory=list)
    truncated: list[np.ndarray] = field(default_factory=list)
    episodes: list[dict[str, Any]] = field(default_factory=list)
    """``info["episode"]`` of every episode that ended inside this rollout, in order."""
    memory: list[Memory] = field(default_factory=list)
    """Recurrent only: one :class:`Memory` per row."""

    def add(
        self,
        *,
        obs: ObsBatch,
        choosing: Tensor,
        running: Tensor,
        available: Tensor,
        joint: Tensor,
        log_prob: Tensor,
        value: Tensor,
        reward_sum: np.ndarray,
        reward_discounted: np.ndarray,
        duration: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        next_value: Tensor,
        memory: Memory | None = None,
    ) -> None:
        """Append one row (one option step of every environment); ``obs`` is dense (acting's).
        A recurrent learner gives every row its ``memory``."""
        self.vectors.append(obs.vectors)
        if obs.images is not None:
            fresh = choosing.bool() if self.image_index else torch.ones_like(choosing.bool())
            index = self.image_index[-1].clone() if self.image_index else choosing.long()
            for e, i in fresh.nonzero().tolist():
                index[e, i] = len(self.bank)
                self.bank.append(obs.images[e, i].clone())  # not a view: frees the row
            self.image_index.append(index)
        self.choosing.append(choosing)
        self.running.append(running)
        self.available.append(available)
        self.joint.append(joint)
        self.log_prob.append(log_prob)
        self.value.append(value)
        self.reward_sum.append(np.asarray(reward_sum, dtype=np.float64))
        self.reward_discounted.append(np.asarray(reward_discounted, dtype=np.float64))
        self.duration.append(np.asarray(duration, dtype=np.int64))
        self.terminated.append(np.asarray(terminated, dtype=bool))
        self.truncated.append(np.asarray(truncated, dtype=bool))
        self.next_value.append(next_value)
        if memory is not None:
            self.memory.append(memory)

    @property
    def num_steps(self) -> int:
        return len(self.vectors)

    @property
    def ticks(self) -> int:
        """Low-level samples in the rollout (the sum of all option durations)."""
        return int(np.sum(self.duration)) if self.duration else 0

    def grid(self, name: str) -> np.ndarray:
        """A per-row field stacked as an ``[S, E]`` numpy array."""
        rows = getattr(self, name)
        return np.stack([r.numpy() if isinstance(r, Tensor) else r for r in rows])

    def advantages(
        self,
        value_norm: ValueNorm | None,
        *,
        gamma: float,
        lam: float,
        form: DiscountForm | str,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(advantages, returns, values)``, each ``[S, E]`` in return units."""
        values, next_values = self.grid("value"), self.grid("next_value")
        if value_norm is not None:
            values = value_norm.denormalize(torch.from_numpy(values).double()).numpy()
            next_values = value_norm.denormalize(torch.from_numpy(next_values).double()).numpy()
        done = self.grid("terminated") | self.grid("truncated")
        continues = ~done
        continues[-1] = False
        advantages, returns = compute_gae(
            values=values,
            next_values=next_values,
            reward_sum=self.grid("reward_sum"),
            reward_discounted=self.grid("reward_discounted"),
            durations=self.grid("duration"),
            terminated=self.grid("terminated"),
            continues=continues,
            gamma=gamma,
            lam=lam,
            form=form,
        )
        return advantages, returns, values

    def training_batch(self, advantages: np.ndarray, returns: np.ndarray) -> TrainBatch:
        """Flatten the grid row-major (index ``s * E + e``) into a :class:`TrainBatch`."""
        images = torch.stack(self.bank) if self.bank else None
        index = torch.cat(self.image_index) if self.image_index else None
        recurrent = {}
        if self.memory:
            recurrent = {
                name: torch.cat([getattr(m, name) for m in self.memory])
                for name in ("starts", "policy_state", "critic_state")
            }
        return TrainBatch(
            obs=ObsBatch(torch.cat(self.vectors), images, index),
            choosing=torch.cat(self.choosing),
            running=torch.cat(self.running),
            available=torch.cat(self.available),
            joint=torch.cat(self.joint),
            old_log_prob=torch.cat(self.log_prob).float(),
            old_value=torch.cat(self.value).float(),
            returns=torch.from_numpy(returns.reshape(-1)).float(),
            advantages=torch.from_numpy(advantages.reshape(-1)).float(),
            num_envs=self.num_envs,
            epsilon=torch.full((advantages.size,), self.epsilon) if self.epsilon else None,
            **recurrent,
        )

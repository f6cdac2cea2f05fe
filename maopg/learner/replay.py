"""Mac-DQN's squeezed replay: one transition per decision point (docs/DESIGN.md §6).

Xiao, Hoffman & Amato (2019) train macro-action Q-learning only on *squeezed* experience: the
ticks between two decision points collapse into one transition that carries their γ-discounted
reward and their count ``k``, so the bootstrap is ``γ^k max Q(z', ·)``. Rows are held per
environment until the episode ends, so whole episodes can also be replayed in order (the
recurrent Q-network).
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import torch
from torch import Tensor

from maopg.env.contract import DecisionPoint, EnvSpec


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
        fields["images"] = ((n, *spec.image_shape), np.dtype(spec.image_channels.dtype))
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
        arrays["images"] = np.array(point.images)  # the env's dtype (uint8, float32 with depth)
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

    The ring is numpy in host memory whatever the learner's device: rows arrive one decision
    point at a time from the CPU simulation and the ring is checkpointed as it is, while an
    update needs only its sampled batch (64 rows, or 16 episodes) on the device, which
    :class:`~maopg.learner.macdqn.MacDQN` moves there.
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

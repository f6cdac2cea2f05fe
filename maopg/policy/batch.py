"""Batching decision points into tensors for the policy, the critic and the learners.

A :class:`~maopg.env.contract.DecisionPoint` holds numpy arrays owned by the environment (they are
overwritten on the next step), so everything here *copies* into fresh tensors. The layout is the
one every network in :mod:`maopg.policy` consumes:

- observation vectors of all agents concatenated in ``EnvSpec.agents`` order, ``float32 [B, ΣD_i]``
  (encoders slice an agent's segment out with :func:`vector_slices`);
- camera images stacked per agent, ``uint8 [B, N, H, W, 3]`` (kept as bytes: 4x less memory in a
  rollout buffer; encoders divide by 255);
- the condition of the conditional policy: ``choosing`` ``bool [B, N]``, ``running``
  ``int64 [B, N]`` and the availability masks concatenated, ``bool [B, ΣK_i]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from maopg.env.contract import DecisionPoint, EnvSpec


@dataclass
class ObsBatch:
    """Joint observations of ``B`` decision points."""

    vectors: Tensor
    """``float32 [B, ΣD_i]``: the agents' observation vectors concatenated in spec order."""
    images: Tensor | None = None
    """``uint8 [B, N, H, W, 3]`` per-agent camera images, or ``None`` when images are off."""

    @staticmethod
    def from_decision_points(points: Sequence[DecisionPoint]) -> ObsBatch:
        """Stack the observations of ``points`` (copies: the environment reuses its buffers)."""
        if not points:
            raise ValueError("cannot batch an empty sequence of decision points")
        vectors = np.stack(
            [np.concatenate(p.vectors).astype(np.float32, copy=False) for p in points]
        )
        images = None
        if points[0].images is not None:
            images = torch.from_numpy(np.stack([p.images for p in points]))
        return ObsBatch(torch.from_numpy(vectors), images)

    def __len__(self) -> int:
        return self.vectors.shape[0]

    def __getitem__(self, index: Tensor | slice | int) -> ObsBatch:
        """Rows ``index`` of the batch (minibatching); an ``int`` keeps a batch dimension of 1."""
        if isinstance(index, int):
            index = slice(index, index + 1)
        images = None if self.images is None else self.images[index]
        return ObsBatch(self.vectors[index], images)

    def to(self, device: torch.device | str) -> ObsBatch:
        images = None if self.images is None else self.images.to(device)
        return ObsBatch(self.vectors.to(device), images)

    @staticmethod
    def cat(batches: Sequence[ObsBatch]) -> ObsBatch:
        """Concatenate batches along the batch dimension (e.g. rollouts of several workers)."""
        images = None
        if batches[0].images is not None:
            images = torch.cat([b.images for b in batches])  # type: ignore[misc]
        return ObsBatch(torch.cat([b.vectors for b in batches]), images)


def stack_conditions(points: Sequence[DecisionPoint]) -> tuple[Tensor, Tensor, Tensor]:
    """``(choosing bool [B, N], running int64 [B, N], available bool [B, ΣK_i])`` of ``points``."""
    choosing = torch.from_numpy(np.stack([p.choosing for p in points]).astype(bool))
    running = torch.from_numpy(np.stack([p.running for p in points]).astype(np.int64))
    available = torch.from_numpy(
        np.stack([np.concatenate(p.available) for p in points]).astype(bool)
    )
    return choosing, running, available


def vector_slices(spec: EnvSpec) -> tuple[slice, ...]:
    """Column range of each agent's vector inside :attr:`ObsBatch.vectors`."""
    slices, start = [], 0
    for agent in spec.agents:
        slices.append(slice(start, start + agent.vector_size))
        start += agent.vector_size
    return tuple(slices)

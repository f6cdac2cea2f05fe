"""Batching decision points into tensors for the policy, the critic and the learners.

A :class:`~maopg.env.contract.DecisionPoint` holds numpy arrays owned by the environment (they are
overwritten on the next step), so everything here *copies* into fresh tensors. The layout is the
one every network in :mod:`maopg.policy` consumes:

- observation vectors of all agents concatenated in ``EnvSpec.agents`` order, ``float32 [B, ΣD_i]``
  (encoders slice an agent's segment out with :func:`vector_slices`);
- camera images stacked per agent, ``[B, N, H, W, planes]`` as the environment gives them
  (colour alone: ``uint8 [B, N, H, W, 3]``, kept as bytes, 4x less memory in a rollout buffer;
  ``float32`` with depth: :class:`~maopg.sim.channels.ImageChannels`); encoders normalise them;
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
    """Joint observations of ``B`` decision points.

    Images (``[.., H, W, planes]`` in the environment's dtype, see the module docstring) come
    in one of two forms. *Dense* (``image_index`` is ``None``): ``images`` is ``[B, N, H, W,
    planes]``, every agent's camera at every point — what acting builds from decision points.
    *Banked*: ``images`` is a bank ``[M, H, W, planes]`` of distinct images
    and ``image_index`` ``int64 [B, N]`` says which one agent ``n`` saw at point ``b``; a
    continuing agent's camera does not change between its decisions, so a rollout stores (and
    an update encodes) each image once (:meth:`maopg.learner.buffer.Rollout.add`).
    """

    vectors: Tensor
    """``float32 [B, ΣD_i]``: the agents' observation vectors concatenated in spec order."""
    images: Tensor | None = None
    """Dense ``[B, N, H, W, planes]``, or the bank ``[M, H, W, planes]``; ``None`` without
    images."""
    image_index: Tensor | None = None
    """``int64 [B, N]`` rows of the bank (banked form only)."""
    ticks: Tensor | None = None
    """``int64 [B]``: the ticks since reset at each point (:attr:`DecisionPoint.ticks`), for a
    network that embeds when an observation was received (ACAC's); ``None`` where not kept."""
    states: Tensor | None = None
    """``float32 [B, S]``: the task's global state at each point (:attr:`DecisionPoint.state`),
    for a critic that reads it; ``None`` where the task has none or it is not kept."""

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
        ticks = torch.tensor([p.ticks for p in points], dtype=torch.int64)
        states = None
        if points[0].state is not None:
            states = torch.from_numpy(np.stack([p.state for p in points]).astype(np.float32))
        return ObsBatch(torch.from_numpy(vectors), images, ticks=ticks, states=states)

    def __len__(self) -> int:
        return self.vectors.shape[0]

    def __getitem__(self, index: Tensor | slice | int) -> ObsBatch:
        """Rows ``index`` of the batch (minibatching); an ``int`` keeps a batch dimension of 1.
        A banked batch keeps only the images its rows use."""
        if isinstance(index, int):
            index = slice(index, index + 1)
        ticks = None if self.ticks is None else self.ticks[index]
        states = None if self.states is None else self.states[index]
        if self.image_index is not None:
            bank, rows = compact_bank(self.images, self.image_index[index])  # type: ignore[arg-type]
            return ObsBatch(self.vectors[index], bank, rows, ticks, states)
        images = None if self.images is None else self.images[index]
        return ObsBatch(self.vectors[index], images, ticks=ticks, states=states)

    def to(self, device: torch.device | str) -> ObsBatch:
        images = None if self.images is None else self.images.to(device)
        index = None if self.image_index is None else self.image_index.to(device)
        ticks = None if self.ticks is None else self.ticks.to(device)
        states = None if self.states is None else self.states.to(device)
        return ObsBatch(self.vectors.to(device), images, index, ticks, states)

    def dense_images(self) -> Tensor | None:
        """``[B, N, H, W, planes]`` whatever the form (a banked batch gathers its bank)."""
        if self.images is None or self.image_index is None:
            return self.images
        return self.images[self.image_index]


def compact_bank(bank: Tensor, index: Tensor) -> tuple[Tensor, Tensor]:
    """The images of ``bank`` that ``index`` uses, once each, and ``index`` renumbered."""
    used, renumbered = torch.unique(index, return_inverse=True)
    return bank[used], renumbered.view(index.shape)


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

"""Option-level memory: a GRU over the decision points a network has acted on (docs/DESIGN.md §5).

Water Filling is partially observable (a jar's level is known only where a robot last looked),
so a feed-forward policy sees nearly the same observation at consecutive decision points and
repeats itself. :class:`OptionMemory` sits between an encoder and a head and carries a hidden
state from one decision point to the next, as rMAPPO does per time step.

**Slots.** The state is ``[B, S, H]``: one slot per encoder of the network — one for the
centralized policy and the critic (a joint state that advances at every joint decision point),
one per agent for the partially centralized policy, whose slot ``i`` advances only where agent
``i`` chooses (``advancing``), so an agent that continues keeps its state: its observation has
not changed and it decided nothing. The autoregressive policy (``async-ar``) has both, the
joint slot first; ``partial-ar`` has the per-agent slots only.

**Resets.** ``starts`` marks the first decision point of an episode (``ticks == 0``): the state
is zeroed there before the point is read, so no history crosses an episode boundary, at
collection as inside a training chunk.

**Step and sequence.** :meth:`OptionMemory.step` advances one decision point per row (acting,
collection); :meth:`OptionMemory.sequence` re-runs chunks of consecutive decision points from
their stored initial state (truncated backpropagation through the chunk) with the very same
cell, one step at a time, so both compute the same numbers (up to the float rounding of a
different batch size: ~1e-7 on the CPU, ``tests/learner/test_recurrent.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor, nn


class OptionMemory(nn.Module):
    """One GRU cell per slot over features of size ``size`` (module docstring)."""

    def __init__(self, size: int, slots: int = 1) -> None:
        super().__init__()
        self.size = size
        self.cells = nn.ModuleList(nn.GRUCell(size, size) for _ in range(slots))
        for cell in self.cells:  # rMAPPO's GRU initialisation: orthogonal weights, zero biases
            for name, parameter in cell.named_parameters():
                if name.startswith("weight"):
                    nn.init.orthogonal_(parameter)
                else:
                    nn.init.zeros_(parameter)

    @property
    def slots(self) -> int:
        return len(self.cells)

    def initial_state(self, batch: int) -> Tensor:
        """Zero state ``[batch, S, H]`` for ``batch`` fresh episodes."""
        return torch.zeros(batch, self.slots, self.size, device=self.cells[0].weight_hh.device)

    def step(
        self,
        features: Sequence[Tensor],
        state: Tensor,
        starts: Tensor,
        advancing: Tensor | None = None,
    ) -> tuple[list[Tensor], Tensor]:
        """Read one decision point per row: ``features`` (one ``[B, H]`` per slot), the state
        carried into it ``[B, S, H]``, ``starts`` ``bool [B]`` (episode starts: zeroed first) and
        ``advancing`` ``bool [B, S]`` (``None``: every slot). Returns the per-slot outputs (the
        new state of an advancing slot, the carried one of a frozen slot) and the new state."""
        if len(features) != self.slots:
            raise ValueError(f"{self.slots} memory slots, got {len(features)} feature tensors")
        state = state * (~starts.to(state.device)).to(state.dtype).view(-1, 1, 1)
        outputs = []
        for slot, (cell, x) in enumerate(zip(self.cells, features, strict=True)):
            carried = state[:, slot]
            new = cell(x, carried)
            if advancing is not None:
                new = torch.where(advancing[:, slot : slot + 1].to(new.device), new, carried)
            outputs.append(new)
        return outputs, torch.stack(outputs, dim=1)

    def sequence(
        self,
        features: Sequence[Tensor],
        state: Tensor,
        starts: Tensor,
        advancing: Tensor | None = None,
    ) -> list[Tensor]:
        """:meth:`step` along ``C`` chunks of ``L`` points: ``features`` one ``[C*L, H]`` per slot
        (row ``c * L + t``), ``state`` ``[C, S, H]`` carried into each chunk, ``starts``
        ``bool [C, L]``, ``advancing`` ``bool [C, L, S]``. Returns per-slot outputs
        ``[C*L, H]``; gradients flow back through the chunk (truncated at its start)."""
        chunks, length = starts.shape
        steps = [x.view(chunks, length, -1) for x in features]
        outputs: list[list[Tensor]] = [[] for _ in self.cells]
        for t in range(length):
            out, state = self.step(
                [x[:, t] for x in steps],
                state,
                starts[:, t],
                None if advancing is None else advancing[:, t],
            )
            for slot, value in enumerate(out):
                outputs[slot].append(value)
        return [torch.stack(slot, dim=1).reshape(chunks * length, -1) for slot in outputs]

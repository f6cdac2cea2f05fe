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

**Option history.** With ``option_counts`` (``ppo.option_history``) every cell also reads what
the team is doing: the one-hot of each agent's option at the point (the running one of a
continuing agent, the one that just ended for a choosing agent, none at reset) and who chooses.
An encoder's features alone are nearly the same at consecutive points at a jar, so a GRU fed
only them settles to the same state there; the macro-action literature's histories are of
(macro-action, observation) pairs, and the options are what tell the tenth ``Fill(j)`` in a
row from the first. The critic's memory reads them too, where a feed-forward critic sees
nothing of the options the continuing agents are bound to.

**Normalisation.** With ``norm`` (``ppo.memory_norm``) each slot's features are layer-normalised
before its cell and its output after it, while the state carried on stays the cell's own, as in
rMAPPO, whose GRU reads the output of a LayerNorm and whose ``RNNLayer`` normalises what it
returns. The encoders end in a ReLU with no normalisation: their features are large (norms of
300–400 over 128 units in trained Water Filling policies, ``bench/analysis/memory_scale.py``), which
drive a GRU's sigmoid and tanh gates into saturation, where a step barely moves them; the
outputs, bounded by the tanh, are small beside the features a feed-forward head reads, so the
head's logits move little per update.

**Step and sequence.** :meth:`OptionMemory.step` advances one decision point per row (acting,
collection); :meth:`OptionMemory.sequence` re-runs chunks of consecutive decision points from
their stored initial state (truncated backpropagation through the chunk) with the very same
cell, one step at a time, so both compute the same numbers (up to the float rounding of a
different batch size: ~1e-7 on the CPU, ``tests/learner/test_recurrent.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import torch
from torch import Tensor, nn


def option_history(choosing: Tensor, running: Tensor, option_counts: Sequence[int]) -> Tensor:
    """``float [B, ΣK_i + N]``: each agent's one-hot option at the points (``running``; all
    zeros for ``-1``, the reset point) and then ``choosing`` (module docstring)."""
    parts = [
        nn.functional.one_hot(running[:, i].clamp(min=0), k).float()
        * (running[:, i : i + 1] >= 0).float()
        for i, k in enumerate(option_counts)
    ]
    return torch.cat([*parts, choosing.float()], dim=-1)


@dataclass(frozen=True)
class MemoryDesign:
    """Which memory a network carries, as one argument: the policy and the critic of a run
    carry the same one (``ppo.recurrent``, ``ppo.option_history``, ``ppo.memory_norm``), and
    the last two mean nothing without the first."""

    recurrent: bool = False
    option_history: bool = False
    """Recurrent only: the cells also read the option history (module docstring)."""
    norm: bool = False
    """Recurrent only: the cells' features and outputs are layer-normalised (module docstring)."""

    def __post_init__(self) -> None:
        if not self.recurrent and (self.option_history or self.norm):
            raise ValueError("option_history and norm are parts of the memory: recurrent")

    def build(self, option_counts: Sequence[int], size: int, slots: int) -> OptionMemory | None:
        """The memory of a network with ``slots`` encoders of ``size`` features for a team with
        these option sets (``None``: feed-forward)."""
        if not self.recurrent:
            return None
        counts = option_counts if self.option_history else None
        return OptionMemory(size, slots, counts, norm=self.norm)


FEED_FORWARD = MemoryDesign()
"""No memory: a network that reads only the current decision point."""


class OptionMemory(nn.Module):
    """One GRU cell per slot over features of size ``size``, and over the option history where
    ``option_counts`` is given (module docstring)."""

    def __init__(
        self,
        size: int,
        slots: int = 1,
        option_counts: Sequence[int] | None = None,
        norm: bool = False,
    ) -> None:
        super().__init__()
        self.size = size
        self.norms = (
            nn.ModuleList(
                nn.ModuleList([nn.LayerNorm(size), nn.LayerNorm(size)]) for _ in range(slots)
            )
            if norm
            else None
        )
        self.option_counts = None if option_counts is None else tuple(option_counts)
        extra = 0 if option_counts is None else sum(option_counts) + len(option_counts)
        self.cells = nn.ModuleList(nn.GRUCell(size + extra, size) for _ in range(slots))
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

    def history(self, choosing: Tensor, running: Tensor) -> Tensor | None:
        """What the cells read beside the features at points with these conditions
        (:func:`option_history`), or ``None`` for a memory of features alone."""
        if self.option_counts is None:
            return None
        return option_history(choosing, running, self.option_counts)

    def step(
        self,
        features: Sequence[Tensor],
        state: Tensor,
        starts: Tensor,
        advancing: Tensor | None = None,
        history: Tensor | None = None,
    ) -> tuple[list[Tensor], Tensor]:
        """Read one decision point per row: ``features`` (one ``[B, H]`` per slot), the state
        carried into it ``[B, S, H]``, ``starts`` ``bool [B]`` (episode starts: zeroed first),
        ``advancing`` ``bool [B, S]`` (``None``: every slot) and ``history`` (:meth:`history`,
        read by every slot). Returns the per-slot outputs (the new state of an advancing slot,
        the carried one of a frozen slot) and the new state."""
        if len(features) != self.slots:
            raise ValueError(f"{self.slots} memory slots, got {len(features)} feature tensors")
        if (history is None) != (self.option_counts is None):
            raise ValueError(
                "a memory of the option history needs history=, one of features alone takes none"
            )
        state = state * (~starts.to(state.device)).to(state.dtype).view(-1, 1, 1)
        outputs, states = [], []
        for slot, (cell, x) in enumerate(zip(self.cells, features, strict=True)):
            carried = state[:, slot]
            if self.norms is not None:
                x = self.norms[slot][0](x)
            if history is not None:
                x = torch.cat([x, history.to(x.dtype)], dim=-1)
            new = cell(x, carried)
            if advancing is not None:
                new = torch.where(advancing[:, slot : slot + 1].to(new.device), new, carried)
            states.append(new)
            outputs.append(new if self.norms is None else self.norms[slot][1](new))
        return outputs, torch.stack(states, dim=1)

    def sequence(
        self,
        features: Sequence[Tensor],
        state: Tensor,
        starts: Tensor,
        advancing: Tensor | None = None,
        history: Tensor | None = None,
    ) -> list[Tensor]:
        """:meth:`step` along ``C`` chunks of ``L`` points: ``features`` one ``[C*L, H]`` per slot
        (row ``c * L + t``), ``state`` ``[C, S, H]`` carried into each chunk, ``starts``
        ``bool [C, L]``, ``advancing`` ``bool [C, L, S]``, ``history`` ``[C*L, E]``. Returns
        per-slot outputs ``[C*L, H]``; gradients flow back through the chunk (truncated at its
        start)."""
        chunks, length = starts.shape
        steps = [x.view(chunks, length, -1) for x in features]
        past = None if history is None else history.view(chunks, length, -1)
        outputs: list[list[Tensor]] = [[] for _ in self.cells]
        for t in range(length):
            out, state = self.step(
                [x[:, t] for x in steps],
                state,
                starts[:, t],
                None if advancing is None else advancing[:, t],
                None if past is None else past[:, t],
            )
            for slot, value in enumerate(out):
                outputs[slot].append(value)
        return [torch.stack(slot, dim=1).reshape(chunks * length, -1) for slot in outputs]

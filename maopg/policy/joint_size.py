"""How big a network over the whole joint option set gets, and a refusal before it is built.

A head with one output per joint option (the product categorical, Mac-DQN's ``Q(z, ·)``) has
``ΠK_i`` outputs: 54 for Tool Delivery, 6^7·8 ≈ 2.2 million for a team of eight. Building one
that cannot fit does not fail cleanly — torch allocates until the kernel kills the process,
minutes into a run and with nothing said. So the builders estimate the memory first and refuse
with the joint size, what it would need and what to use instead.

The estimate counts what certainly exists, in float32: the head's weights ``(hidden + 1)·ΠK``
times the copies the learner keeps of them (weights, gradient, Adam's two moments, a target
network), plus the rows of ``ΠK`` values one update holds at once. The limit is half the memory
the networks train in: the machine's, or for a run on a GPU the lesser of the machine's
(networks are built on the CPU, then moved) and the GPU's. Every policy builder is told what it
builds for — a :class:`BuildTarget`: that memory, and the run's batch, which bounds how many
decision points an update holds — and hands it to :func:`require_joint_head_fits`.
"""

from __future__ import annotations

import math
import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import torch

FLOAT_BYTES = 4


@dataclass(frozen=True)
class BuildTarget:
    """What the networks being built will train in and on."""

    memory: int
    """Bytes (0: unknown, then nothing is refused)."""
    where: str
    """Whose memory it is, as the refusal says it: ``this machine's``, ``the GPU's (...)``."""
    batch_ticks: int = 1
    """The run's ticks per update: an update holds at most about this many decision points (one
    per tick of each environment), so a joint head's rows are bounded by it."""

    @classmethod
    def for_training(cls, device: torch.device | str, *, batch_ticks: int) -> BuildTarget:
        """A run's: ``device``'s memory (:func:`training_memory`) and its batch."""
        memory, where = training_memory(device)
        return cls(memory, where, batch_ticks)

    @classmethod
    def this_machine(cls) -> BuildTarget:
        """This machine's memory and one decision point: a policy built to act, not to train."""
        return cls(machine_memory(), "this machine's")


def joint_size(option_counts: Sequence[int]) -> int:
    """``ΠK_i``: the number of joint options."""
    return math.prod(option_counts)


def describe_joint(option_counts: Sequence[int]) -> str:
    """``6^7·8 = 2,239,488``: the joint size as a product of powers, then its value."""
    counts = Counter(option_counts)
    factors = [f"{k}^{n}" if n > 1 else f"{k}" for k, n in counts.most_common()]
    return f"{'·'.join(factors)} = {joint_size(option_counts):,}"


def joint_head_bytes(option_counts: Sequence[int], *, hidden: int, copies: int, rows: int) -> int:
    """The memory of a joint head and one update over it (module docstring)."""
    size = joint_size(option_counts)
    return FLOAT_BYTES * size * (copies * (hidden + 1) + rows)


def machine_memory() -> int:
    """Physical memory of this machine in bytes (0 where the platform does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def training_memory(device: torch.device | str) -> tuple[int, str]:
    """The memory networks on ``device`` train in, in bytes (0: unknown), and whose it is."""
    host = machine_memory()
    device = torch.device(device)
    if device.type != "cuda":
        return host, "this machine's"
    gpu = torch.cuda.get_device_properties(device).total_memory
    if host and host < gpu:
        return host, "this machine's"
    return gpu, f"the GPU's ({torch.cuda.get_device_name(device)})"


def require_joint_head_fits(
    option_counts: Sequence[int],
    *,
    hidden: int,
    copies: int,
    rows: int,
    who: str,
    instead: str,
    target: BuildTarget,
) -> None:
    """Raise a :class:`ValueError` naming the joint size when the head would not fit in half of
    ``target``'s memory; ``who`` is the network, ``instead`` the way out."""
    memory, where = target.memory, target.where
    need = joint_head_bytes(option_counts, hidden=hidden, copies=copies, rows=rows)
    if memory and need > memory // 2:
        gib = 2.0**30
        raise ValueError(
            f"{who} has one output per joint option: this team's {len(option_counts)} agents "
            f"have {describe_joint(option_counts)} joint options, which need at least "
            f"{need / gib:,.1f} GiB (half of {where} {memory / gib:.0f} GiB is the "
            f"limit); {instead}"
        )

"""How big a network over the whole joint option set gets, and a refusal before it is built.

A head with one output per joint option (the product categorical, Mac-DQN's ``Q(z, ·)``) has
``ΠK_i`` outputs: 54 for Tool Delivery, 6^7·8 ≈ 2.2 million for a team of eight. Building one
that cannot fit does not fail cleanly — torch allocates until the kernel kills the process,
minutes into a run and with nothing said. So the builders estimate the memory first and refuse
with the joint size, what it would need and what to use instead.

The estimate counts what certainly exists, in float32: the head's weights ``(hidden + 1)·ΠK``
times the copies the learner keeps of them (weights, gradient, Adam's two moments, a target
network), plus the rows of ``ΠK`` values one update holds at once. It is a lower bound — the
real peak is higher — so the limit is half the machine's memory.
"""

from __future__ import annotations

import math
import os
from collections import Counter
from collections.abc import Sequence

FLOAT_BYTES = 4


def joint_size(option_counts: Sequence[int]) -> int:
    """``ΠK_i``: the number of joint options."""
    return math.prod(option_counts)


def describe_joint(option_counts: Sequence[int]) -> str:
    """``6^7·8 = 2,239,488``: the joint size as a product of powers, then its value."""
    counts = Counter(option_counts)
    factors = [f"{k}^{n}" if n > 1 else f"{k}" for k, n in counts.most_common()]
    return f"{'·'.join(factors)} = {joint_size(option_counts):,}"


def joint_head_bytes(option_counts: Sequence[int], *, hidden: int, copies: int, rows: int) -> int:
    """Lower bound on the memory of a joint head and one update over it (module docstring)."""
    size = joint_size(option_counts)
    return FLOAT_BYTES * size * (copies * (hidden + 1) + rows)


def machine_memory() -> int:
    """Physical memory of this machine in bytes (0 where the platform does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def require_joint_head_fits(
    option_counts: Sequence[int],
    *,
    hidden: int,
    copies: int,
    rows: int,
    who: str,
    instead: str,
    memory: int | None = None,
) -> None:
    """Raise a :class:`ValueError` naming the joint size when the head would not fit in half of
    ``memory`` (default: this machine's); ``who`` is the network, ``instead`` the way out."""
    memory = machine_memory() if memory is None else memory
    need = joint_head_bytes(option_counts, hidden=hidden, copies=copies, rows=rows)
    if memory and need > memory // 2:
        gib = 2.0**30
        raise ValueError(
            f"{who} has one output per joint option: this team's {len(option_counts)} agents "
            f"have {describe_joint(option_counts)} joint options, which need at least "
            f"{need / gib:,.1f} GiB (half of this machine's {memory / gib:.0f} GiB is the "
            f"limit); {instead}"
        )

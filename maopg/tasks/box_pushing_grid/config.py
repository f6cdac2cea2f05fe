"""Box Pushing's config, in a module of its own: the registry reads its defaults and validates
overrides without importing the rules."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from maopg.settings import setting
from maopg.tasks.config import TaskConfig

SIZES = (4, 6, 8, 10)
"""The grid sizes the canonical layouts exist for (4x4: the original paper's smallest; 6, 8
and 10: the ACAC runs)."""


@dataclass(frozen=True)
class Config(TaskConfig):
    """Box Pushing settings; the defaults are those of the reference's published runs (bp6)."""

    HAS_STATE: ClassVar[bool] = True

    size: int = setting(6, choices=SIZES)
    """Side of the square grid, in cells."""
    agents: int = setting(2, choices=(2, 3))
    """Team size: the canonical two, or three (the canonical env's third agent starts in the
    middle of the second row, facing north)."""
    max_ticks: int = 100
    """The horizon: the ACAC runner's 100 steps (the env itself has no time limit); a timeout is
    a truncation, never a termination."""
    big_box_reward: float = 300.0
    """Paid when the big box reaches the goal row."""
    small_box_reward: float = 20.0
    """Paid when a small box reaches the goal row."""
    penalty: float = -10.0
    """Paid for a Push into a wall, into a box from the side, or alone into the big box."""
    step_reward: float = -0.1
    """Paid every tick (hard-coded in the canonical env)."""

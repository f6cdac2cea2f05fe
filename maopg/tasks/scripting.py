"""What a task's scripted (hand-written reference) policy reads and returns.

Scripted policies live with their tasks, below the environment layer, so they cannot name the
environment's :class:`~maopg.env.contract.DecisionPoint`; :class:`DecisionView` lists the
fields they read, and any decision point provides them. A task registers a
:data:`ScriptedFactory`: given the task's config (the option sets and observation layouts follow
from it) it returns the policy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from maopg.options.base import Option, option_index
from maopg.tasks.config import TaskConfig


class DecisionView(Protocol):
    """The fields of a decision point a scripted policy reads."""

    @property
    def vectors(self) -> Sequence[np.ndarray]:
        """Per-agent observation vectors (laid out as the task's ``observation_layout``)."""

    @property
    def choosing(self) -> np.ndarray:
        """``bool [N]``: agents that choose now."""

    @property
    def running(self) -> np.ndarray:
        """``int64 [N]``: each agent's running (or just ended) option."""

    @property
    def available(self) -> Sequence[np.ndarray]:
        """Per-agent ``bool`` masks over its options: what it may choose now (all of them
        unless the task masks, as Tool Delivery's ``mask_options``)."""

    @property
    def ticks(self) -> int:
        """Ticks since reset."""


ScriptedPolicy = Callable[[DecisionView], np.ndarray]
"""Maps a decision point to a joint option (entries of agents that do not choose are kept)."""
ScriptedFactory = Callable[[TaskConfig], ScriptedPolicy]
"""Builds a task's scripted policy for one config; raises ``ValueError`` for configs it cannot
drive (primitive actions)."""


def option_finder(
    option_sets: Sequence[Sequence[Option[Any]]], agents: Sequence[str]
) -> Callable[[int, str], int]:
    """``find(agent, name)``: the id of an agent's option, from the option sets a config gives
    (a scripted policy chooses options by name, never by position)."""
    names = [[o.name for o in options] for options in option_sets]

    def find(agent: int, name: str) -> int:
        return option_index(names[agent], name, agents[agent])

    return find

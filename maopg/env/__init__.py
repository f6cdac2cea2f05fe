"""Option-level environments: the scheduler, its contract and the PettingZoo adapter."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from maopg.env.contract import AgentSpec, DecisionPoint, EnvSpec, Strategy
from maopg.env.option_env import OptionEnv
from maopg.tasks import load


def make_env(
    task: str,
    strategy: Strategy | str = Strategy.CONTINUE,
    *,
    seed: int = 0,
    images: bool = False,
    image_size: int = 64,
    gamma: float = 0.99,
    overrides: Mapping[str, Any] | None = None,
) -> OptionEnv:
    """Build task ``task`` and wrap it in an :class:`OptionEnv` with ``strategy``.

    ``primitive`` strategy switches the task to its one-tick primitive actions.
    """
    strategy = Strategy(strategy)
    config = {
        "images": images,
        "image_size": image_size,
        "primitive": strategy is Strategy.PRIMITIVE,
        **(overrides or {}),
    }
    return OptionEnv(load(task, config), strategy, gamma=gamma, seed=seed)


__all__ = ["AgentSpec", "DecisionPoint", "EnvSpec", "OptionEnv", "Strategy", "make_env"]

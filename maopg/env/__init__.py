"""Option-level environments: the scheduler, its contract and the PettingZoo adapter."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from maopg.env.contract import AgentSpec, DecisionPoint, EnvSpec, Strategy
from maopg.env.option_env import OptionEnv
from maopg.tasks import load

OWN_ARGUMENTS = {
    "images": "the run's images (images=true, --images)",
    "image_size": "the run's image_size (image_size=84)",
    "primitive": "the method (--method end2end acts in primitive actions)",
}
"""Task settings that :func:`make_env` sets from its own arguments (a run's ``images`` and
``image_size``, its method's strategy): an ``env.`` override of them would contradict the run's
setting, and ``config.json`` would record the overridden value."""


def check_overrides(overrides: Mapping[str, Any]) -> None:
    """Refuse task overrides of :data:`OWN_ARGUMENTS`, naming the setting to use instead."""
    for key, instead in OWN_ARGUMENTS.items():
        if key in overrides:
            raise ValueError(
                f"env.{key}={overrides[key]!r} is not a task override: it is set by {instead}"
            )


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
    check_overrides(overrides or {})
    config = {
        "images": images,
        "image_size": image_size,
        "primitive": strategy is Strategy.PRIMITIVE,
        **(overrides or {}),
    }
    return OptionEnv(load(task, config), strategy, gamma=gamma, seed=seed)


__all__ = ["AgentSpec", "DecisionPoint", "EnvSpec", "OptionEnv", "Strategy", "make_env"]

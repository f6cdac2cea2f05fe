"""Option-level environments: the scheduler, its contract and the PettingZoo adapter.

The contract's classes and :class:`OptionEnv` are imported on first use (:mod:`maopg.exports`):
what a run's config reads here (:data:`OWN_ARGUMENTS`, the ``ray.*`` settings of
:mod:`.ray_options`) loads without numpy or MuJoCo."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from maopg.exports import lazy_exports
from maopg.options.base import Strategy
from maopg.tasks import load

if TYPE_CHECKING:
    from maopg.env.option_env import OptionEnv

_, __getattr__, __dir__ = lazy_exports(
    __name__,
    (
        "maopg.env.contract:AgentSpec",
        "maopg.env.contract:DecisionPoint",
        "maopg.env.contract:EnvSpec",
        "maopg.env.option_env:OptionEnv",
    ),
)

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
    from maopg.env.option_env import OptionEnv

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

"""Experiments: the training config, the method registry, the run directory, the training loop,
loading a trained policy, and the evaluation and reproduction tools behind ``python -m train``
and ``python -m eval`` (``maopg-train`` / ``maopg-eval`` once installed).

``from maopg.experiment import load_policy`` is the way to act with a trained policy from
Python (:mod:`maopg.experiment.inference`). It is imported on first use: the command lines
import this package before they may import MuJoCo (they check ``MUJOCO_GL`` first), so the
package itself imports nothing.
"""

from __future__ import annotations

from typing import Any

__all__ = ["Policy", "load_policy"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from maopg.experiment import inference

        return getattr(inference, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

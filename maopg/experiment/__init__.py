"""Experiments: everything above the learner, one package per concern, imported bottom-up:

- :mod:`.run` — what a run is: its config, the method registry, its directory, lock and loggers;
- :mod:`.evaluation` — using a trained policy: loading it, acting with it, evaluating it;
- :mod:`.training` — the training loop, its progress and ETA;
- :mod:`.studies` — named grids of runs, their tables, figures and cached evaluations;
- :mod:`.cli` — ``python -m train`` and ``python -m eval`` (``maopg-train`` / ``maopg-eval``).

What a user's Python needs is here: ``from maopg.experiment import load_policy`` acts with a
trained policy (:mod:`.evaluation.inference`); ``Method`` and ``register_method`` add a method
to the registry (:mod:`.run.methods`). They are imported on first use: the command lines import
this package before they may import MuJoCo (they check ``MUJOCO_GL`` first), so the package
itself imports nothing.
"""

from __future__ import annotations

from typing import Any

__all__ = ["Method", "Policy", "load_policy", "register_method"]


def __getattr__(name: str) -> Any:
    if name in ("Policy", "load_policy"):
        from maopg.experiment.evaluation import inference

        return getattr(inference, name)
    if name in ("Method", "register_method"):
        from maopg.experiment.run import methods

        return getattr(methods, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

"""What an evaluation evaluated, recorded beside its outcome (``eval evaluate --json``).

A return alone cannot be traced to what produced it: the same checkpoint plays another robot
under other task settings, and a plugin's task or robot is whatever its file held that day. So
the record names the task, its strategy and every one of its settings as the environment was
built (robots included, the defaults filled in), who acted — a checkpoint's method, training
seed, file and sample count, or a reference policy — and each plugin the process imported,
its file with that file's SHA-256 (:func:`maopg.plugins.imported_plugins`).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from typing import Any

from maopg.env import OptionEnv
from maopg.experiment.evaluation.loading import Trained
from maopg.plugins import imported_plugins


def _plain(value: Any) -> Any:
    """A setting JSON cannot hold as it is: a mapping as a dict, anything else as its repr."""
    return dict(value) if isinstance(value, Mapping) else repr(value)


def provenance(env: OptionEnv, acting: dict[str, Any]) -> dict[str, Any]:
    """The record of an evaluation in ``env`` of the policy ``acting`` describes
    (:func:`checkpoint_acting`, :func:`reference_acting`)."""
    config = env.task.config
    settings = {f.name: getattr(config, f.name) for f in dataclasses.fields(config)}
    return {
        "task": env.spec.task,
        "strategy": env.strategy.value,
        "env": json.loads(json.dumps(settings, default=_plain)),
        "policy": acting,
        "plugins": imported_plugins(),
    }


def checkpoint_acting(trained: Trained, *, greedy: bool) -> dict[str, Any]:
    """A checkpoint's policy: its method, training seed, file (absolute), sample count, and
    whether it acted greedily."""
    return {
        "method": trained.config.method,
        "seed": trained.config.seed,
        "checkpoint": str(trained.path.resolve()),
        "samples": trained.samples,
        "greedy": greedy,
    }


def reference_acting(name: str) -> dict[str, Any]:
    """A reference policy (:data:`maopg.env.rollout.REFERENCE_POLICIES`) by its name."""
    return {"reference": name}

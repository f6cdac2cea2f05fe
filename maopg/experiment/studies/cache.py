"""Cached evaluations, keyed on what their numbers depend on.

An evaluation of a study (the reference policies, each seed-0 policy greedy and sampled) is
deterministic and, on Water Filling, takes minutes, so its summaries are stored beside what
they describe (``reference.json`` in a results folder, ``evaluation.json`` in a run directory)
and made again only when an input changes: the episode count, the task settings, the weights
(their sha256), the robot and scene models (``assets/``, their sha256), and the behaviour
versions that the task, the policy and the evaluator declare
(:attr:`maopg.tasks.Task.behaviour_version`, :attr:`maopg.policy.OptionPolicy.behaviour_version`,
:data:`maopg.experiment.evaluation.evaluate.BEHAVIOUR_VERSION`). A change to the code that leaves
every behaviour as it was (a refactor, a docstring) leaves the caches valid;
``tests/test_behaviour_versions.py`` catches a behaviour that changed while its version did not.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from maopg.experiment.evaluation.evaluate import BEHAVIOUR_VERSION as EVALUATOR_VERSION
from maopg.sim.assets import ASSETS_DIR
from maopg.tasks import task_class


def sha256(paths: Sequence[Path], root: Path) -> str:
    """sha256 over ``paths`` (each named relative to ``root``, then its bytes)."""
    digest = hashlib.sha256()
    for path in paths:
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()


@functools.cache
def assets_digest() -> str:
    """sha256 of the robot and scene models every task builds from (read once a process: every
    cached evaluation's key holds it)."""
    return sha256(sorted(p for p in ASSETS_DIR.rglob("*") if p.is_file()), ASSETS_DIR)


def behaviour(tasks: Sequence[str], policy: type | None = None) -> dict:
    """The declared versions an evaluation of ``tasks`` (by ``policy``, a network class) rests
    on, with the assets' digest: part of every cache key."""
    key: dict = {
        "tasks": {task: task_class(task).behaviour_version for task in tasks},
        "evaluator": EVALUATOR_VERSION,
        "assets": assets_digest(),
    }
    if policy is not None:
        key["policy"] = policy.behaviour_version
    return key


def weights_key(episodes: int, task: str, policy: type, weights: Path) -> dict:
    """The key of an evaluation of ``episodes`` episodes on ``task`` by the weights in the file
    ``weights`` (of a ``policy`` network): what it rests on, the file's sha256 included."""
    return {
        "episodes": episodes,
        **behaviour([task], policy),
        "weights": sha256([weights], weights.parent),
    }


def cached(path: Path, key: dict, compute: Callable[[], list[dict]]) -> list[dict]:
    """The summaries stored in ``path`` if they were made for ``key``, else computed and stored
    (delete the file to redo)."""
    if path.exists():
        saved = json.loads(path.read_text())
        if saved["key"] == key:
            return saved["results"]
    results = compute()
    path.write_text(json.dumps({"key": key, "results": results}, indent=2) + "\n")
    return results


def stored(path: Path, matching: Mapping[str, object] | None = None) -> list[dict] | None:
    """The summaries stored in ``path`` whatever inputs they were made from (``None``: no
    file): what stands for an evaluation whose inputs cannot be read back to check its key (a
    clean clone keeps no weights but seed 0's). ``matching``: the parts of the key that must
    still hold (the versions of what they measured), else ``None``."""
    if not path.exists():
        return None
    saved = json.loads(path.read_text())
    if any(saved["key"].get(name) != value for name, value in (matching or {}).items()):
        return None
    return saved["results"]

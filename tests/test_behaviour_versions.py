"""Every built-in task's and method's behaviour is pinned to the version it declares.

Cached evaluations are keyed on declared behaviour versions
(:mod:`maopg.experiment.studies.cache`), not on the bytes of the code, so a refactor leaves them
valid. This test keeps the versions honest: it plays each built-in task's scripted and random
policies under each strategy (and renders its cameras), and each built-in method's freshly
initialised, seeded policy greedy and sampled, and compares a digest of what happened with the
digest recorded for the declared version in ``tests/data/behaviour_fingerprints.json``.

A failure means a behaviour changed. If the change is meant, raise the version the message
names (``behaviour_version`` of the task or policy class) and record the new digests::

    MAOPG_RECORD_BEHAVIOUR=1 python -m pytest tests/test_behaviour_versions.py -n 0

Floats are rounded before they are hashed (observations to 1e-5, rewards to 1e-6, images to
the mean of each channel at 0.1), so the digest is about behaviour, not the last bits of one
machine's arithmetic.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np
import pytest
import torch

from maopg.env import DecisionPoint, make_env
from maopg.env.rollout import REFERENCE_POLICIES, reference_policy
from maopg.experiment.methods import get_method, method_names
from maopg.tasks import SceneTask, task_class, task_entry, task_names

FINGERPRINTS = Path(__file__).parent / "data" / "behaviour_fingerprints.json"
RECORD = os.environ.get("MAOPG_RECORD_BEHAVIOUR") == "1"
STRATEGIES = ("continue", "any", "all")
MAX_TICKS = 30
"""Ticks of each fingerprint episode: enough for every option kind to start and end."""

BUILT_IN_TASKS = [t for t in task_names() if str(task_entry(t).task).startswith("maopg.")]
BUILT_IN_METHODS = [
    m for m in method_names() if get_method(m).learner.__module__.startswith("maopg.")
]


def _point_record(point: DecisionPoint) -> list:
    return [
        point.ticks,
        point.choosing.tolist(),
        point.running.tolist(),
        [np.round(v, 5).tolist() for v in point.vectors],
        [a.tolist() for a in point.available],
        round(float(point.reward), 6),
        bool(point.terminated),
        bool(point.truncated),
    ]


def task_fingerprint(task: str, settings: dict | None = None) -> str:
    """sha256 of the scripted and random policies' episodes under each strategy, and of a
    scene's cameras' first images (``settings``: task settings over its defaults)."""
    records: list = []
    for strategy in STRATEGIES:
        overrides = {"max_ticks": MAX_TICKS, **(settings or {})}
        env = make_env(task, strategy, seed=0, overrides=overrides)
        try:
            for name in REFERENCE_POLICIES:
                policy = reference_policy(name, env, seed=0)
                point = env.reset()
                records.append(_point_record(point))
                while not point.done:
                    point = env.step(policy(point))
                    records.append(_point_record(point))
        finally:
            env.close()
    if issubclass(task_class(task), SceneTask):
        env = make_env(task, seed=0, images=True, image_size=32, overrides={"max_ticks": 5})
        try:
            images = env.reset().images
            if images is not None:
                records.append(np.round(images.mean(axis=(1, 2)), 1).tolist())
        finally:
            env.close()
    return hashlib.sha256(json.dumps(records).encode()).hexdigest()


def policy_fingerprint(method_name: str) -> tuple[str, int]:
    """sha256 of a freshly initialised, seeded policy's greedy and sampled options over a
    Tool Delivery episode of seeded random options, and its class's declared version."""
    method = get_method(method_name)
    env = make_env("tool_delivery", method.strategy, seed=0, overrides={"max_ticks": MAX_TICKS})
    try:
        torch.manual_seed(0)
        policy = method.build_policy(env.spec, hidden=32, layers=1, config=method.default_config())
        random = reference_policy("random", env, seed=0)
        points = [env.reset()]
        while not points[-1].done:
            points.append(env.step(random(points[-1])))
    finally:
        env.close()
    records = []
    for greedy in (True, False):
        actor = method.learner.actor(policy, method.default_config(), greedy=greedy, seed=0)
        records.append([np.asarray(actor(p)).tolist() for p in points[:-1]])
    digest = hashlib.sha256(json.dumps(records).encode()).hexdigest()
    return digest, type(policy).behaviour_version


def _recorded() -> dict:
    return json.loads(FINGERPRINTS.read_text()) if FINGERPRINTS.exists() else {}


def _check(kind: str, name: str, version: int, digest: str, owner: str) -> None:
    if RECORD:
        data = _recorded()
        data.setdefault(kind, {})[name] = {"version": version, "digest": digest}
        FINGERPRINTS.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
        return
    recorded = _recorded().get(kind, {}).get(name)
    assert recorded is not None, f"{name} has no recorded fingerprint: record it (module docstring)"
    assert recorded["version"] == version, (
        f"{owner}.behaviour_version is {version}, the fingerprint is recorded for "
        f"{recorded['version']}: record it (module docstring)"
    )
    assert recorded["digest"] == digest, (
        f"{name}'s behaviour changed while {owner}.behaviour_version stayed {version}: "
        "raise it and record the new fingerprint (module docstring), so cached evaluations "
        "are made again"
    )


@pytest.mark.parametrize("task", BUILT_IN_TASKS)
def test_a_task_behaves_as_its_declared_version(task: str) -> None:
    cls = task_class(task)
    _check("tasks", task, cls.behaviour_version, task_fingerprint(task), cls.__name__)


@pytest.mark.parametrize("method", BUILT_IN_METHODS)
def test_a_methods_policy_acts_as_its_declared_version(method: str) -> None:
    digest, version = policy_fingerprint(method)
    _check("policies", method, version, digest, f"{method}'s policy class")


def test_the_fingerprint_sees_a_change_of_the_rules() -> None:
    """A shorter human stage or a quicker search changes Tool Delivery's digest."""
    recorded = _recorded()["tasks"]["tool_delivery"]["digest"]
    assert task_fingerprint("tool_delivery", {"human_stage_ticks": 9}) != recorded
    assert task_fingerprint("tool_delivery", {"search_ticks": 5}) != recorded

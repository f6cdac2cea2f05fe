"""Every built-in task's and method's behaviour is pinned to the version it declares.

Cached evaluations are keyed on declared behaviour versions
(:mod:`maopg.experiment.studies.cache`), not on the bytes of the code, so a refactor leaves them
valid. This test keeps the versions honest: it plays each built-in task's scripted and random
policies under each strategy over its whole horizon (and its cameras at every decision point
of a scripted episode), again at each registered study's settings, and each built-in method's
freshly initialised, seeded policy greedy and sampled from state and from cameras, and compares
a digest of what happened with the digest recorded for the declared version in
``tests/data/behaviour_fingerprints.json``.

A failure means a behaviour changed. If the change is meant, raise the version the message
names (``behaviour_version`` of the task or policy class) and record the new digests::

    MAOPG_RECORD_BEHAVIOUR=1 python -m pytest tests/test_behaviour_versions.py -n 0

Floats are rounded before they are hashed (observations to 1e-5, rewards to 1e-6), so the digest
is about behaviour, not the last bits of one machine's arithmetic; camera images are recorded as
each channel's mean and compared within :data:`COLOUR_TOLERANCE`.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import torch

from maopg.env import DecisionPoint, OptionEnv, make_env
from maopg.env.rollout import REFERENCE_POLICIES, ReferencePolicy, reference_policy
from maopg.experiment.run.methods import get_method, method_names
from maopg.experiment.studies import get_study, study_names
from maopg.sim.look_draws import LOOKS_VERSION
from maopg.sim.looks import OFF
from maopg.tasks import SceneTask, make_config, task_class, task_entry, task_names

FINGERPRINTS = Path(__file__).parent / "data" / "behaviour_fingerprints.json"
RECORD = os.environ.get("MAOPG_RECORD_BEHAVIOUR") == "1"
STRATEGIES = ("continue", "any", "all")
MAX_TICKS = 30
"""Ticks of a policy's fingerprint episode from state: enough for every option to be chosen."""
IMAGE_SIZE = 36
"""The smallest image the CNN encoder reads."""
IMAGE_TICKS = 10
"""Ticks of a policy's fingerprint episode from its cameras."""
STUDY_TICKS = 60
"""Ticks of a task's fingerprint episodes at a study's settings (teams of eight are slow);
at its default settings a task plays its whole horizon."""

BUILT_IN_TASKS = [t for t in task_names() if str(task_entry(t).task).startswith("maopg.")]
MACHINE_DEPENDENT = {
    'water_filling {"drones": 4, "jars": 8, "vehicles": 4}': "its evaluations differ between AMD "
    "EPYC and Intel (results/README.md): a floating-point difference that grows over an "
    "episode, not traced (numpy's CPU-specific SIMD code on the four drones' arrays is the "
    "likely source)",
}
"""Study settings whose trajectories are bit-exact per machine only: no recorded digest can
hold on every machine, so they are not fingerprinted (why, per case)."""
STUDY_SETTINGS = {
    f"{t.task} {json.dumps(dict(t.settings), sort_keys=True)}": (t.task, dict(t.settings))
    for name in study_names()
    for t in get_study(name).tasks
    if t.task in BUILT_IN_TASKS and make_config(t.task, t.settings) != make_config(t.task)
}
"""Each task at each study's settings: the evaluations a study caches run there."""
LOOKS = ("full", "heldout", "mounts")
"""The randomised looks the vision study trains and evaluates in (``env.appearance``): what a
look draws is part of a scene task's behaviour there, so its fingerprint is pinned to the
task's version and to :data:`~maopg.sim.look_draws.LOOKS_VERSION` together."""
STUDY_SETTINGS.update(
    {
        f"{task} {json.dumps({'appearance': look})}": (task, {"appearance": look})
        for task in BUILT_IN_TASKS
        if issubclass(task_class(task), SceneTask)
        for look in LOOKS
    }
)
for case in MACHINE_DEPENDENT:
    STUDY_SETTINGS.pop(case, None)
BUILT_IN_METHODS = [
    m for m in method_names() if get_method(m).learner_class.__module__.startswith("maopg.")
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


def _episode(env: OptionEnv, policy: ReferencePolicy, record: Callable) -> list:
    point = env.reset()
    records = [record(point)]
    while not point.done:
        point = env.step(policy(point))
        records.append(record(point))
    return records


def _images(point: DecisionPoint) -> list:
    """The mean colour of each camera's image at ``point`` (0-255), to 0.01."""
    return [] if point.images is None else np.round(point.images.mean(axis=(1, 2)), 2).tolist()


def task_fingerprint(
    task: str, settings: dict | None = None, max_ticks: int | None = None
) -> tuple[str, list]:
    """sha256 of the scripted and random policies' episodes under each strategy and, for a
    scene, its cameras' mean colours at every decision point of a scripted episode (compared
    with a tolerance: a rasteriser may round a pixel differently on another CPU);
    ``settings``: task settings over its defaults, ``max_ticks``: a shorter horizon than the
    task's own."""
    overrides = {**(settings or {}), **({"max_ticks": max_ticks} if max_ticks else {})}
    records: list = []
    for strategy in STRATEGIES:
        env = make_env(task, strategy, seed=0, overrides=overrides)
        try:
            for name in REFERENCE_POLICIES:
                records += _episode(env, reference_policy(name, env, seed=0), _point_record)
        finally:
            env.close()
    colours: list = []
    if issubclass(task_class(task), SceneTask):
        env = make_env(task, seed=0, images=True, image_size=32, overrides=overrides)
        try:
            colours = _episode(env, reference_policy("scripted", env), _images)
        finally:
            env.close()
    return hashlib.sha256(json.dumps(records).encode()).hexdigest(), colours


def policy_fingerprint(method_name: str) -> tuple[str, int]:
    """sha256 of a freshly initialised, seeded policy's greedy and sampled options over Tool
    Delivery episodes of seeded random options, from state and from 36 px cameras (the image
    encoder's path), and its class's declared version."""
    method = get_method(method_name)
    records = []
    for images, ticks in ((False, MAX_TICKS), (True, IMAGE_TICKS)):
        overrides = {"max_ticks": ticks}
        env = make_env(
            "tool_delivery",
            method.strategy,
            seed=0,
            images=images,
            image_size=IMAGE_SIZE,
            overrides=overrides,
        )
        try:
            torch.manual_seed(0)
            config = method.default_config()
            policy = method.build_policy(env.spec, hidden=32, layers=1, config=config)
            points = _episode(env, reference_policy("random", env, seed=0), lambda p: p)
        finally:
            env.close()
        for greedy in (True, False):
            actor = method.learner_class.actor(policy, config, greedy=greedy, seed=0)
            records.append([np.asarray(actor(p)).tolist() for p in points[:-1]])
    digest = hashlib.sha256(json.dumps(records).encode()).hexdigest()
    return digest, type(policy).behaviour_version


def _recorded() -> dict:
    return json.loads(FINGERPRINTS.read_text()) if FINGERPRINTS.exists() else {}


COLOUR_TOLERANCE = 0.5
"""How far (0-255) a camera's mean colour may move before it counts as a change: a few pixels
rounded differently move it by thousandths, a moved camera or a new colour by far more."""


def _check(
    kind: str,
    name: str,
    version: int | str,
    digest: str,
    owner: str,
    colours: list | None = None,
) -> None:
    if RECORD:
        data = _recorded()
        entry = {"version": version, "digest": digest}
        data.setdefault(kind, {})[name] = {**entry, **({"colours": colours} if colours else {})}
        FINGERPRINTS.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
        return
    recorded = _recorded().get(kind, {}).get(name)
    assert recorded is not None, f"{name} has no recorded fingerprint: record it (module docstring)"
    assert recorded["version"] == version, (
        f"{owner}.behaviour_version is {version}, the fingerprint is recorded for "
        f"{recorded['version']}: record it (module docstring)"
    )
    changed = (
        "raise it and record the new fingerprint (module docstring), so cached evaluations "
        "are made again"
    )
    assert recorded["digest"] == digest, (
        f"{name}'s behaviour changed while {owner}.behaviour_version stayed {version}: {changed}"
    )
    expected = recorded.get("colours", [])
    same_shape = len(expected) == len(colours or []) and all(
        np.shape(a) == np.shape(b) for a, b in zip(expected, colours or [], strict=False)
    )
    assert same_shape and all(
        np.allclose(a, b, atol=COLOUR_TOLERANCE, rtol=0)
        for a, b in zip(expected, colours or [], strict=True)
    ), f"{name}'s camera images changed while {owner}.behaviour_version stayed {version}: {changed}"


@pytest.mark.parametrize("task", BUILT_IN_TASKS)
def test_a_task_behaves_as_its_declared_version(task: str) -> None:
    cls = task_class(task)
    digest, colours = task_fingerprint(task)
    _check("tasks", task, cls.behaviour_version, digest, cls.__name__, colours)


@pytest.mark.parametrize("case", sorted(STUDY_SETTINGS))
def test_a_task_at_a_studys_settings_behaves_as_its_declared_version(case: str) -> None:
    task, settings = STUDY_SETTINGS[case]
    cls = task_class(task)
    digest, colours = task_fingerprint(task, settings, max_ticks=STUDY_TICKS)
    version: int | str = cls.behaviour_version
    owner = cls.__name__
    if settings.get("appearance", OFF) != OFF:
        version, owner = f"{version}+looks{LOOKS_VERSION}", f"{owner} (or LOOKS_VERSION)"
    _check("tasks", case, version, digest, owner, colours)


@pytest.mark.parametrize("method", BUILT_IN_METHODS)
def test_a_methods_policy_acts_as_its_declared_version(method: str) -> None:
    digest, version = policy_fingerprint(method)
    _check("policies", method, version, digest, f"{method}'s policy class")


def test_the_fingerprint_sees_a_change_of_the_rules() -> None:
    """A shorter human stage or a quicker search changes Tool Delivery's digest."""
    recorded = _recorded()["tasks"]["tool_delivery"]["digest"]
    assert task_fingerprint("tool_delivery", {"human_stage_ticks": 9})[0] != recorded
    assert task_fingerprint("tool_delivery", {"search_ticks": 5})[0] != recorded

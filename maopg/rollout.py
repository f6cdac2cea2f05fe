"""Reference policies (scripted, uniform random) and episode rollouts.

The two reference policies are the levels every learning curve is read against;
``python -m eval evaluate --reference scripted|random`` evaluates them from the command line.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from maopg.env import DecisionPoint, EnvSpec, OptionEnv, make_env


class ReferencePolicy(Protocol):
    """Chooses a joint option at a decision point (entries of non-choosing agents ignored)."""

    def __call__(self, point: DecisionPoint) -> np.ndarray: ...


class RandomPolicy:
    """Uniform over each choosing agent's available options."""

    def __init__(self, spec: EnvSpec, seed: int = 0) -> None:
        self.spec = spec
        self.rng = np.random.default_rng(seed)

    def __call__(self, point: DecisionPoint) -> np.ndarray:
        joint = point.running.copy()
        for i in np.flatnonzero(point.choosing):
            joint[i] = self.rng.choice(np.flatnonzero(point.available[i]))
        return joint


REFERENCE_POLICIES = ("scripted", "random")


def reference_policy(name: str, task: str, spec: EnvSpec, seed: int = 0) -> ReferencePolicy:
    """``scripted`` (the task's own) or ``random`` (uniform, seeded) for ``task``."""
    if name == "random":
        return RandomPolicy(spec, seed)
    if name == "scripted":
        return scripted_policy(task, spec)
    raise ValueError(f"unknown reference policy {name!r}; known: {REFERENCE_POLICIES}")


def scripted_policy(task: str, spec: EnvSpec) -> ReferencePolicy:
    """The task module's hand-written policy (``scripted_policy(spec)`` in the module)."""
    module = importlib.import_module(f"maopg.tasks.{task}")
    if not hasattr(module, "scripted_policy"):
        raise ValueError(f"task {task!r} has no scripted policy")
    return module.scripted_policy(spec)


@dataclass
class EpisodeResult:
    ret: float
    ticks: int
    solved: bool
    decisions: int
    rewards: list[float]
    """Summed reward of every decision step (the paper's metric averages these)."""


def run_episode(
    env: OptionEnv,
    policy: ReferencePolicy,
    seed: int | None = None,
    on_step: Callable[[DecisionPoint], None] | None = None,
) -> EpisodeResult:
    """Play one episode to its end; ``on_step`` sees every decision point (e.g. for videos)."""
    point = env.reset(seed=seed)
    rewards: list[float] = []
    if on_step:
        on_step(point)
    while not point.done:
        point = env.step(policy(point))
        rewards.append(point.reward)
        if on_step:
            on_step(point)
    episode = point.info["episode"]
    return EpisodeResult(
        episode["return"], episode["ticks"], episode["solved"], len(rewards), rewards
    )


def evaluate_reference(
    task: str,
    policy: str,
    episodes: int,
    seed: int = 0,
    strategy: str = "continue",
    overrides: dict[str, object] | None = None,
) -> list[EpisodeResult]:
    """``episodes`` episodes of the reference policy ``policy`` (``scripted`` | ``random``) on a
    fresh ``task`` environment: the levels a learning curve is read against, in one call."""
    env = make_env(task, strategy, seed=seed, overrides=overrides)
    try:
        pol = reference_policy(policy, task, env.spec, seed)
        return [run_episode(env, pol) for _ in range(episodes)]
    finally:
        env.close()

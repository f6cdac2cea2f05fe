"""Reference policies (scripted, uniform random) and episode rollouts.

The two reference policies are the levels every learning curve is read against;
``python -m eval evaluate --reference scripted|random`` evaluates them from the command line.
A task's scripted policy is declared in its registry entry and built from the task's config.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from maopg.env import DecisionPoint, EnvSpec, OptionEnv, make_env
from maopg.tasks import task_entry


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


def reference_policy(name: str, env: OptionEnv, seed: int = 0) -> ReferencePolicy:
    """``scripted`` (the task's own, for ``env``'s task config) or ``random`` (uniform, seeded)."""
    if name == "random":
        return RandomPolicy(env.spec, seed)
    if name == "scripted":
        return scripted_policy(env)
    raise ValueError(f"unknown reference policy {name!r}; known: {REFERENCE_POLICIES}")


def scripted_policy(env: OptionEnv) -> ReferencePolicy:
    """The scripted policy registered for ``env``'s task, built from the task's config."""
    task = env.task
    factory = task_entry(task.name).scripted_factory()
    if factory is None:
        raise ValueError(f"task {task.name!r} has no scripted policy")
    return factory(task.config)


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
        pol = reference_policy(policy, env, seed)
        return [run_episode(env, pol) for _ in range(episodes)]
    finally:
        env.close()

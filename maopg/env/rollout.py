"""Reference policies (scripted, uniform random) and episode rollouts.

The two reference policies are the levels every learning curve is read against;
``python -m eval evaluate --reference scripted|random`` evaluates them from the command line.
A task's scripted policy is declared in its registry entry and built from the task's config.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
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
    """Summed reward of every completed decision step (the paper's metric averages these)."""
    cut: bool = False
    """The episode went on past ``max_ticks`` of :func:`run_episode` and was stopped there:
    ``ret`` is then the return of its first ``ticks`` ticks, and it is not ``solved``."""


class TickLimit(Exception):
    """Raised by a tick listener to leave an episode mid-step at a tick limit."""


def goes_on_past(env: OptionEnv, limit: int) -> bool:
    """Whether the tick ``env`` just played is tick ``limit`` (or later) and the episode does
    not end on it: where an episode bounded at ``limit`` ticks is cut, in the middle of an
    option if need be (an option may run until the task's ``max_ticks``)."""
    task = env.task
    ends = task.terminated() or task.truncated() or task.ticks >= env.spec.max_ticks
    return task.ticks >= limit and not ends


def run_episode(
    env: OptionEnv,
    policy: ReferencePolicy,
    seed: int | None = None,
    on_step: Callable[[DecisionPoint], None] | None = None,
    max_ticks: int | None = None,
) -> EpisodeResult:
    """Play one episode to its end; ``on_step`` sees every decision point (e.g. for videos).

    With ``max_ticks`` an episode still running at that tick is cut there (``cut``), so its
    length is bounded whatever the task's ``max_ticks`` (a user may set a billion); ``env`` is
    then left mid-episode (reset it before stepping it again).
    """
    point = env.reset(seed=seed)
    rewards: list[float] = []
    played = [0.0]  # the return so far, tick by tick: a cut ends mid-step

    def on_tick(tick_env: OptionEnv, reward: float) -> None:
        played[0] += reward
        if goes_on_past(tick_env, max_ticks):  # type: ignore[arg-type]
            raise TickLimit

    if max_ticks is not None:
        env.add_tick_listener(on_tick)
    try:
        if on_step:
            on_step(point)
        while not point.done:
            point = env.step(policy(point))
            rewards.append(point.reward)
            if on_step:
                on_step(point)
    except TickLimit:
        return EpisodeResult(played[0], env.task.ticks, False, len(rewards), rewards, cut=True)
    finally:
        if max_ticks is not None:
            env.remove_tick_listener(on_tick)
    episode = point.info["episode"]
    return EpisodeResult(
        episode["return"], episode["ticks"], episode["solved"], len(rewards), rewards
    )


def decision_points(env: OptionEnv, policy: ReferencePolicy, count: int) -> Iterator[DecisionPoint]:
    """``count`` decision points of ``env`` under ``policy``, episode after episode (an ended
    episode is followed by a reset): a stream of states to measure or check something on."""
    point = env.reset()
    for _ in range(count):
        point = env.step(policy(point))
        if point.done:
            point = env.reset()
        yield point


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

"""Reference policies (scripted, uniform random) and episode rollouts, with a small CLI.

    python -m maopg.rollout --task tool_delivery --policy scripted --episodes 10

prints the mean ± std episode return: the two reference points every learning curve is read
against (DESIGN §7: scripted ≈ 259, random ≈ −66 on the canonical Tool Delivery task).
"""

from __future__ import annotations

import argparse
import importlib
import json
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
    env = make_env(task, strategy, seed=seed, overrides=overrides)
    try:
        pol = (
            RandomPolicy(env.spec, seed) if policy == "random" else scripted_policy(task, env.spec)
        )
        return [run_episode(env, pol) for _ in range(episodes)]
    finally:
        env.close()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="tool_delivery")
    parser.add_argument("--policy", choices=("scripted", "random"), default="scripted")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--strategy", default="continue")
    parser.add_argument(
        "--set",
        nargs="*",
        default=[],
        metavar="KEY=VALUE",
        help="task config overrides, e.g. turtlebot_robot=diffbot (values parsed as JSON)",
    )
    args = parser.parse_args(argv)
    overrides = {}
    for item in args.set:
        key, sep, text = item.partition("=")
        if not sep:
            parser.error(f"--set {item!r} is not of the form KEY=VALUE")
        try:
            overrides[key] = json.loads(text)
        except json.JSONDecodeError:
            overrides[key] = text
    results = evaluate_reference(
        args.task, args.policy, args.episodes, args.seed, args.strategy, overrides
    )
    returns = np.array([r.ret for r in results])
    ticks = np.array([r.ticks for r in results])
    solved = np.mean([r.solved for r in results])
    print(
        f"{args.task} {args.policy} ({args.strategy}, {args.episodes} episodes, seed {args.seed}): "
        f"return {returns.mean():.1f} ± {returns.std():.1f}, "
        f"length {ticks.mean():.1f} ticks, solved {solved:.0%}"
    )


if __name__ == "__main__":
    main()

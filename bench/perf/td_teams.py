"""Tool Delivery at several team sizes: the scripted and the uniform-random reference returns.

Run: ``.venv/bin/python bench/perf/td_teams.py [--episodes N]``. Prints a Markdown block for
BENCHMARKS.md: per team (turtlebots, fetches, humans) the number of agents and of joint
options, the scripted policy's return and ticks under each strategy (the task is deterministic,
so one episode is every episode), and the random policy's mean ± std return and solved share
over ``--episodes`` episodes (strategy ``continue``), each at the default ``max_ticks`` (150)
and, for ``all``, at 300 (sync-wait's rounds last as long as the slowest option).

The random team's deliveries and failed passes per episode are printed too: they are the
signal a learner starts from: a larger team tries many more passes that fail (-10 each) for
no more deliveries (+100), which makes "never pass" (exactly -150) easy to learn first. Both
counts are read off each tick's reward, ``step + delivery * d + failed_pass * f`` with ``f``
below ``delivery / |failed_pass|`` per tick (one pass per Fetch), so ``d`` and ``f`` follow
from it uniquely; each episode's counts are checked against its return.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from maopg.env import make_env
from maopg.env.option_env import OptionEnv
from maopg.env.rollout import EpisodeResult, reference_policy, run_episode
from maopg.experiment.run.sysinfo import markdown

SIZES = ((2, 1, 1), (3, 1, 1), (2, 1, 2), (4, 2, 2), (6, 2, 3))
"""The canonical team first; (6, 2, 3) is the issue's benchmark team of 8 robots."""
LONG_TICKS = 300


def team(size: tuple[int, int, int]) -> dict[str, int]:
    return dict(zip(("turtlebots", "fetches", "humans"), size, strict=True))


def scripted(size: tuple[int, int, int], strategy: str, max_ticks: int) -> str:
    env = make_env("tool_delivery", strategy, overrides={**team(size), "max_ticks": max_ticks})
    try:
        result = run_episode(env, reference_policy("scripted", env), seed=0)
    finally:
        env.close()
    return f"{result.ret:.0f} ({result.ticks}{'' if result.solved else ', unsolved'})"


def random_episodes(
    size: tuple[int, int, int], episodes: int
) -> tuple[list[EpisodeResult], np.ndarray]:
    """``episodes`` seeded episodes of the uniform-random policy (seed 0, as
    :func:`~maopg.env.rollout.evaluate_reference`) and each one's (deliveries, failed passes)."""
    env = make_env("tool_delivery", seed=0, overrides=team(size))
    c = env.task.config
    counts = np.zeros(2)

    def count(_: OptionEnv, reward: float) -> None:
        gain = reward - c.step_reward
        delivered = max(0, math.ceil(round(gain / c.delivery_reward, 9)))
        failed = round((delivered * c.delivery_reward - gain) / -c.failed_pass_reward)
        counts[:] += (delivered, failed)

    env.add_tick_listener(count)
    results, events = [], []
    try:
        policy = reference_policy("random", env, 0)
        for _ in range(episodes):
            counts[:] = 0
            result = run_episode(env, policy)
            delivered, failed = counts
            decoded = (
                result.ticks * c.step_reward
                + delivered * c.delivery_reward
                + failed * c.failed_pass_reward
            )
            if not math.isclose(decoded, result.ret, abs_tol=1e-6):
                raise RuntimeError(
                    f"ticks' rewards decode to {decoded}, the return is {result.ret}"
                )
            results.append(result)
            events.append(counts.copy())
    finally:
        env.close()
    return results, np.array(events)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=8)
    args = parser.parse_args()
    print("### Tool Delivery team sizes (`bench/perf/td_teams.py`)\n")
    print(markdown())
    print(
        f"- scripted: one episode per strategy (deterministic), return (ticks); random: "
        f"{args.episodes} episodes, seed 0, strategy `continue`; `max_ticks` 150, `all` also "
        f"at {LONG_TICKS}\n"
    )
    print(
        "| turtlebots, fetches, humans | agents | joint options | scripted `continue` "
        f"| scripted `any` | scripted `all` | scripted `all`, {LONG_TICKS} ticks "
        "| random return | random solved | random deliveries | random failed passes |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for size in SIZES:
        env = make_env("tool_delivery", overrides=team(size))
        agents, joint = env.spec.num_agents, math.prod(a.num_options for a in env.spec.agents)
        env.close()
        runs = [scripted(size, s, 150) for s in ("continue", "any", "all")]
        runs.append(scripted(size, "all", LONG_TICKS))
        random, events = random_episodes(size, args.episodes)
        returns = [r.ret for r in random]
        solved = np.mean([r.solved for r in random])
        deliveries, failed = events.mean(axis=0)
        print(
            f"| {', '.join(map(str, size))} | {agents} | {joint:,} | {' | '.join(runs)} "
            f"| {np.mean(returns):.0f} ± {np.std(returns):.0f} | {solved:.0%} "
            f"| {deliveries:.2f} | {failed:.1f} |"
        )


if __name__ == "__main__":
    main()

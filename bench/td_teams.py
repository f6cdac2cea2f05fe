"""Tool Delivery at several team sizes: the scripted and the uniform-random reference returns.

Run: ``.venv/bin/python bench/td_teams.py [--episodes N]``. Prints a Markdown block for
BENCHMARKS.md: per team (turtlebots, fetches, humans) the number of agents and of joint
options, the scripted policy's return and ticks under each strategy (the task is deterministic,
so one episode is every episode), and the random policy's mean ± std return and solved share
over ``--episodes`` episodes (strategy ``continue``), each at the default ``max_ticks`` (150)
and, for ``all``, at 300 (sync-wait's rounds last as long as the slowest option).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from maopg.env import make_env
from maopg.env.rollout import evaluate_reference, reference_policy, run_episode
from maopg.experiment.sysinfo import markdown

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=8)
    args = parser.parse_args()
    print("### Tool Delivery team sizes (`bench/td_teams.py`)\n")
    print(markdown())
    print(
        f"- scripted: one episode per strategy (deterministic), return (ticks); random: "
        f"{args.episodes} episodes, seed 0, strategy `continue`; `max_ticks` 150, `all` also "
        f"at {LONG_TICKS}\n"
    )
    print(
        "| turtlebots, fetches, humans | agents | joint options | scripted `continue` "
        f"| scripted `any` | scripted `all` | scripted `all`, {LONG_TICKS} ticks "
        "| random return | random solved |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for size in SIZES:
        env = make_env("tool_delivery", overrides=team(size))
        agents, joint = env.spec.num_agents, math.prod(a.num_options for a in env.spec.agents)
        env.close()
        runs = [scripted(size, s, 150) for s in ("continue", "any", "all")]
        runs.append(scripted(size, "all", LONG_TICKS))
        random = evaluate_reference(
            "tool_delivery", "random", args.episodes, 0, overrides=team(size)
        )
        returns = [r.ret for r in random]
        solved = np.mean([r.solved for r in random])
        print(
            f"| {', '.join(map(str, size))} | {agents} | {joint:,} | {' | '.join(runs)} "
            f"| {np.mean(returns):.0f} ± {np.std(returns):.0f} | {solved:.0%} |"
        )


if __name__ == "__main__":
    main()

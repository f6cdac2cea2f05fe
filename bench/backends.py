"""Collection throughput of the vector-environment backends, side by side in one run.

Run: ``.venv/bin/python bench/backends.py [--steps N] [--rounds R]``. Prints a Markdown block
for BENCHMARKS.md. Each backend steps 4 environments with the uniform-random reference policy
(the policy's cost is the same for all, and small) for ``--steps`` lockstep option steps; the
backends alternate within each of ``--rounds`` rounds so a change in machine load hits them
alike, and every round also checks that the backends produced the same rollout (rewards and
tick counts of every step). Figures are low-level ticks per second, median over the rounds.

``local`` steps the environments one after another, ``threads`` on 2 threads of this process
(``mj_step`` and rendering release the GIL), ``processes`` in 2 ``spawn``ed workers
(observations cross a pipe).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from maopg.env.rollout import RandomPolicy
from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.experiment.sysinfo import markdown

BACKENDS = ("local", "threads", "processes")
CASES = (("tool_delivery", False), ("tool_delivery", True), ("water_filling", True))


def collect(config: EnvConfig, backend: str, steps: int) -> tuple[float, list]:
    """(ticks per second, the rollout's trace) of ``steps`` lockstep option steps."""
    envs = SeededVectorEnv(config, num_envs=4, seed=0, backend=backend, num_workers=2)
    try:
        envs.reset()
        policy, ticks, trace = RandomPolicy(envs.spec, 0), 0, []
        start = time.perf_counter()
        for _ in range(steps):
            results = envs.step(np.stack([policy(p) for p in envs.points]))
            ticks += sum(r.outcome.duration for r in results)
            trace.append([(r.outcome.reward, r.outcome.ticks) for r in results])
        return ticks / (time.perf_counter() - start), trace
    finally:
        envs.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    rows = []
    for task, images in CASES:
        config = EnvConfig(task=task, strategy="continue", images=images)
        rates: dict[str, list[float]] = {b: [] for b in BACKENDS}
        same = True
        for _ in range(args.rounds):
            traces = []
            for backend in BACKENDS:
                rate, trace = collect(config, backend, args.steps)
                rates[backend].append(rate)
                traces.append(trace)
            same &= all(t == traces[0] for t in traces)
        medians = {b: statistics.median(v) for b, v in rates.items()}
        rows.append((task, "RGB" if images else "state", medians, same))
    print("### Vector-environment backends (`bench/backends.py`)\n")
    print(markdown())
    print(f"- 4 environments, {args.steps} option steps, {args.rounds} rounds, 2 threads/workers\n")
    print("| task | observations | local ticks/s | threads | processes | identical rollouts |")
    print("|---|---|---|---|---|---|")
    for task, kind, m, same in rows:
        ratios = [f"{m[b]:,.0f} ({m[b] / m['local']:.2f}×)" for b in ("threads", "processes")]
        print(f"| {task} | {kind} | {m['local']:,.0f} | {' | '.join(ratios)} | {same} |")


if __name__ == "__main__":
    main()

"""Collection throughput of the vector-environment backends, side by side in one run.

Run: ``.venv/bin/python bench/perf/backends.py [--steps N] [--rounds R]``. Prints a Markdown block
for BENCHMARKS.md. Each backend steps 4 environments with the uniform-random reference policy
(the policy's cost is the same for all, and small) for ``--steps`` lockstep option steps; the
backends alternate within each of ``--rounds`` rounds so a change in machine load hits them
alike, and every round also checks that the backends produced the same rollout (rewards and
tick counts of every step). Figures are low-level ticks per second, median over the rounds.

``local`` steps the environments one after another, ``threads`` on 2 threads of this process
(``mj_step`` and rendering release the GIL), ``processes`` in 2 ``spawn``ed workers
(observations cross a pipe), ``processes×4`` in 4, one per environment (Water Filling's
default backend: the operating system evens out option steps of uneven length over the cores,
``bench/perf/lockstep.py``), ``ray`` in 2 Ray actors of a local Ray instance started once for
the whole benchmark (observations cross each actor's TCP connection, ``ray.direct``), and
``ray×1`` in one actor holding all 4 environments: it steps them one after another like
``local``, so its ratio to ``local`` is the Ray backend's own overhead at the same number of
environments (issue 16: at most 15%). ``ray×1 calls`` is the same with ``ray.direct=false``:
a Ray actor call per option step, observations through Ray's object store. Without Ray
installed (``pip install 'maopg[ray]'``) the Ray columns are left out.
"""

from __future__ import annotations

import argparse
import logging
import statistics
import time

import numpy as np

from maopg.env.ray_backend import ray_available
from maopg.env.rollout import RandomPolicy
from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.experiment.run.sysinfo import markdown

COLUMNS: dict[str, tuple[str, int, dict[str, bool]]] = {
    "local": ("local", 0, {}),
    "threads": ("threads", 2, {}),
    "processes": ("processes", 2, {}),
    "processes×4": ("processes", 4, {}),
    "ray": ("ray", 2, {}),
    "ray×1": ("ray", 1, {}),
    "ray×1 calls": ("ray", 1, {"direct": False}),
}
"""Column → (backend, workers: threads, processes or actors, the backend's options)."""
CASES = (("tool_delivery", False), ("tool_delivery", True), ("water_filling", True))


def collect(config: EnvConfig, column: str, steps: int) -> tuple[float, list]:
    """(ticks per second, the rollout's trace) of ``steps`` lockstep option steps."""
    backend, workers, options = COLUMNS[column]
    envs = SeededVectorEnv(
        config,
        num_envs=4,
        seed=0,
        backend=backend,
        num_workers=workers,
        backend_options=options,
    )
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
    conditions = markdown()
    columns = [c for c in COLUMNS if ray_available() or not c.startswith("ray")]
    if ray_available():
        import ray

        ray.init(num_cpus=2, include_dashboard=False, logging_level=logging.WARNING)
    rows = []
    for task, images in CASES:
        config = EnvConfig(task=task, strategy="continue", images=images)
        rates: dict[str, list[float]] = {c: [] for c in columns}
        same = True
        for _ in range(args.rounds):
            traces = []
            for column in columns:
                rate, trace = collect(config, column, args.steps)
                rates[column].append(rate)
                traces.append(trace)
            same &= all(t == traces[0] for t in traces)
        medians = {c: statistics.median(v) for c, v in rates.items()}
        rows.append((task, "RGB" if images else "state", medians, same))
    print("### Vector-environment backends (`bench/perf/backends.py`)\n")
    print(conditions)
    print(
        f"- 4 environments, {args.steps} option steps, {args.rounds} rounds; 2 threads, "
        "processes or Ray actors (`processes×4`: one process per environment; `ray×1`: one "
        "actor with all 4 environments; `calls`: `ray.direct=false`)\n"
    )
    others = columns[1:]
    print(f"| task | observations | local ticks/s | {' | '.join(others)} | identical rollouts |")
    print("|---|---|---|" + "---|" * len(others) + "---|")
    for task, kind, m, same in rows:
        ratios = [f"{m[c]:,.0f} ({m[c] / m['local']:.2f}×)" for c in others]
        print(f"| {task} | {kind} | {m['local']:,.0f} | {' | '.join(ratios)} | {same} |")


if __name__ == "__main__":
    main()

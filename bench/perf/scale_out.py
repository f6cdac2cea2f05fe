"""Scale-out on paper: what N Ray actors on N machines would collect, and where the learner
becomes the bottleneck — a short model whose inputs are measured here.

Run: ``.venv/bin/python bench/perf/scale_out.py [--task tool_delivery] [--rtt-ms 0.5] [--gbit 1]``.
Prints a Markdown block for BENCHMARKS.md.

Measured on this machine (medians over ``--rounds``):

- ``t_env``: seconds one actor takes per lockstep option step of its environments, per
  environment (``backend=local``, random options: the physics, options and cameras);
- ``d``: low-level ticks per environment per lockstep step (the option durations);
- ``δ(k)``: the Ray backend's own cost per step for an actor with ``k`` environments
  (``ray×1`` minus ``local`` at the same environments, on one machine: pickling and the
  exchange over the actor's connection, ``ray.direct``);
- ``b``: bytes of one environment's answer to a step (what crosses the network);
- ``a(B)``: the learner's acting cost per lockstep step for ``B`` environments (policy and
  critic forward passes in ``collect``), fitted as ``a0 + a1·B``;
- ``u``: the PPO update's seconds per sample (one default iteration's update / its samples).

Model, for ``N`` machines with one actor of ``k`` environments each (``E = N·k``): actors step
in parallel, so a lockstep step takes ``t_step = k·t_env + δ(k) + rtt + E·b / bandwidth +
a(E)`` and yields ``E·d`` ticks; a batch of ``S`` samples is collected in ``S / (E·d) · t_step``
and learned from in ``u·S``, one after the other (on-policy PPO), so ``samples/s = S / (that
sum)``. The learner is the bottleneck once ``u·S`` exceeds the collection time; no number of
machines gets past ``1 / (u + per-sample driver costs)``. The network figures are assumptions
(``--rtt-ms``, ``--gbit``), everything else is measured.
"""

from __future__ import annotations

import argparse
import logging
import pickle
import statistics
import time
from typing import Any

import numpy as np
import torch

from maopg.env.rollout import RandomPolicy
from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.sysinfo import markdown
from maopg.experiment.training.trainer import build_learner


class TimedBackend:
    """A vector-environment backend whose ``step`` calls are timed (the rest delegated)."""

    def __init__(self, inner: Any) -> None:
        self.inner, self.seconds, self.steps = inner, 0.0, 0

    def step(self, joints: np.ndarray, next_seeds: list[int]) -> list:
        start = time.perf_counter()
        results = self.inner.step(joints, next_seeds)
        self.seconds += time.perf_counter() - start
        self.steps += 1
        return results

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


def step_costs(config: EnvConfig, backend: str, k: int, steps: int) -> tuple[float, float, float]:
    """(seconds per lockstep step, ticks per environment per step, bytes per environment's
    answer) of ``k`` environments under random options."""
    envs = SeededVectorEnv(config, num_envs=k, seed=0, backend=backend, num_workers=1)
    try:
        envs.reset()
        policy = RandomPolicy(envs.spec, 0)
        for _ in range(5):  # warm-up: first renders, the actor's first calls
            envs.step(np.stack([policy(p) for p in envs.points]))
        timed = envs.backend = TimedBackend(envs.backend)
        ticks, size = 0, 0
        for _ in range(steps):
            results = envs.step(np.stack([policy(p) for p in envs.points]))
            ticks += sum(r.outcome.duration for r in results)
            size += sum(len(pickle.dumps(r, protocol=5)) for r in results)
        return timed.seconds / steps, ticks / (steps * k), size / (steps * k)
    finally:
        envs.close()


def learner_costs(task: str, num_envs: int, iterations: int) -> tuple[float, float, int]:
    """(acting seconds per lockstep step, update seconds per sample, batch samples) of the
    default ``async`` learner from RGB, over ``iterations`` iterations after one warm-up."""
    config = TrainConfig(task=task, method="async", images=True, num_envs=num_envs).resolved()
    envs = SeededVectorEnv(config.env(), num_envs=num_envs, seed=0, backend="local")
    try:
        envs.reset()
        gens = torch.Generator().manual_seed(0), torch.Generator().manual_seed(1)
        learner = build_learner(config, envs.spec, *gens)
        collect, collect_seconds = learner.collect, [0.0]

        def timed_collect(vector: SeededVectorEnv) -> Any:
            start = time.perf_counter()
            try:
                return collect(vector)
            finally:
                collect_seconds[0] += time.perf_counter() - start

        learner.collect = timed_collect  # type: ignore[method-assign]
        learner.iteration(envs, 0)  # warm-up
        timed = envs.backend = TimedBackend(envs.backend)
        collect_seconds[0], total, samples = 0.0, 0.0, 0
        for _ in range(iterations):
            start = time.perf_counter()
            _, ticks = learner.iteration(envs, 0)
            total += time.perf_counter() - start
            samples += ticks
        acting = (collect_seconds[0] - timed.seconds) / timed.steps
        update = (total - collect_seconds[0]) / samples
        return acting, update, samples // iterations
    finally:
        envs.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="tool_delivery")
    parser.add_argument("--steps", type=int, default=60)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--rtt-ms", type=float, default=0.5, help="network round trip (assumed)")
    parser.add_argument("--gbit", type=float, default=1.0, help="driver bandwidth (assumed)")
    args = parser.parse_args()
    import ray

    torch.set_num_threads(1)  # as training does (torch_threads=1)
    conditions = markdown()
    ray.init(num_cpus=2, include_dashboard=False, logging_level=logging.WARNING)
    config = EnvConfig(task=args.task, strategy="continue", images=True)
    measured: dict[tuple[str, int], list[tuple[float, float, float]]] = {}
    for _ in range(args.rounds):
        for k in (1, 4):
            for backend in ("local", "ray"):
                measured.setdefault((backend, k), []).append(
                    step_costs(config, backend, k, args.steps)
                )
    med = {
        key: [statistics.median(v[i] for v in runs) for i in range(3)]
        for key, runs in measured.items()
    }
    t_env = med[("local", 4)][0] / 4
    ticks_per_step = med[("local", 4)][1]
    payload = med[("local", 4)][2]
    delta = {k: med[("ray", k)][0] - med[("local", k)][0] for k in (1, 4)}
    acting = {b: learner_costs(args.task, b, 2) for b in (4, 16)}
    a1 = (acting[16][0] - acting[4][0]) / 12
    a0 = acting[4][0] - 4 * a1
    update, batch = acting[4][1], acting[4][2]
    ray.shutdown()

    def delta_of(k: int) -> float:  # linear in k through the two measured points
        return delta[1] + (delta[4] - delta[1]) * (k - 1) / 3

    rtt, bandwidth = args.rtt_ms / 1000, args.gbit * 1e9 / 8
    print(f"### Scale-out model, {args.task} RGB (`bench/perf/scale_out.py`)\n")
    print(conditions)
    print(
        f"- measured: t_env = {t_env * 1000:.2f} ms per environment-step, d = "
        f"{ticks_per_step:.2f} ticks per environment-step, b = {payload / 1024:.1f} KiB per "
        f"environment-step, δ(1) = {delta[1] * 1000:.2f} ms, δ(4) = {delta[4] * 1000:.2f} ms, "
        f"a(B) = {a0 * 1000:.2f} + {a1 * 1000:.3f}·B ms, u = {update * 1000:.2f} ms per "
        f"sample (batch S = {batch} samples); {args.rounds} rounds of {args.steps} steps"
    )
    print(f"- assumed network: rtt {args.rtt_ms} ms, {args.gbit} Gbit/s into the learner\n")
    amortise = {f: (delta[4] + rtt) * (1 - f) / (f * t_env) for f in (0.15, 0.05)}
    print(
        f"Ray's overhead on one machine, one actor: {delta[1] / (med[('local', 1)][0]):.0%} "
        f"of a step with 1 environment, {delta[4] / med[('local', 4)][0]:.0%} with 4. Across "
        f"machines an actor needs k ≥ {amortise[0.15]:.1f} environments for the per-step cost "
        f"(δ + rtt) to stay under 15% of its step, k ≥ {amortise[0.05]:.1f} for 5%.\n"
    )
    print(
        "| machines N | envs per actor k | E | step (ms) | collect per batch (s) | update per "
        "batch (s) | samples/s | bottleneck |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for k in (4, 8):
        for n in (1, 2, 4, 8, 16, 32, 64):
            e = n * k
            step = k * t_env + delta_of(k) + rtt + e * payload / bandwidth + a0 + a1 * e
            collect = batch / (e * ticks_per_step) * step
            learn = update * batch
            rate = batch / (collect + learn)
            neck = "learner" if learn > collect else "collection"
            print(
                f"| {n} | {k} | {e} | {step * 1000:.1f} | {collect:.2f} | {learn:.2f} | "
                f"{rate:,.0f} | {neck} |"
            )
    ceiling = 1 / (update + (a1 + payload / bandwidth) / ticks_per_step)
    print(
        f"\nCeiling for any N (collection free, the learner's per-sample costs only): "
        f"{ceiling:,.0f} samples/s."
    )


if __name__ == "__main__":
    main()

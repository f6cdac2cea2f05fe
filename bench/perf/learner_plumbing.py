"""Does the learner's plumbing still pay? Each optimisation on and off, side by side in one run.

Run: ``.venv/bin/python bench/perf/learner_plumbing.py [--cases td-rgb,wf-rgb,td,bp6]
[--rounds 3]``. Prints a Markdown block for BENCHMARKS.md.

1. **The critic's thread** (:mod:`maopg.learner.beside`, ``MAPPO.overlap_critic``): one PPO
   update of a collected batch with the critic's step on its own thread beside the actor's, and
   one after the other. Each case is ``async`` at the command line's defaults for its task
   (backend, batch, network, ``torch_threads``); both ways update from the same weights and
   optimiser state on the same batch, and the table says whether their weights came out
   bit-identical (they must). (At commit 805e0f4 the collection could value each new decision
   point on that thread too, and this script timed it: it gained nothing, so it went.)
2. **The learners' Adam** (:mod:`maopg.learner.adam`) against ``torch.optim.Adam``: what the
   first optimiser step of a fresh process costs — building the optimiser and one step, after
   the learner's modules are imported — each in a fresh subprocess.

The two ways alternate within each of ``--rounds`` rounds, the order swapped every round, so
a change in the machine's load hits both alike; figures are medians (min–max). The verdict
calls a difference noise when the two ranges overlap.
"""

from __future__ import annotations

import argparse
import copy
import statistics
import subprocess
import sys
import time
from collections.abc import Callable

import torch

from maopg.env.vector import SeededVectorEnv
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.sysinfo import markdown
from maopg.experiment.training.trainer import build_learner
from maopg.learner import MAPPOLearner

CASES = {
    "td-rgb": ("tool_delivery", {"images": True}),
    "wf-rgb": ("water_filling", {"images": True}),
    "td": ("tool_delivery", {}),
    "bp6": ("box_pushing_grid", {}),
}
"""Case → (task, run fields): ``async`` at the command line's defaults otherwise."""

FIRST_STEP = """
import sys, time
import torch
import maopg.learner.mappo
from maopg.learner.adam import Adam
torch.manual_seed(0)
net = torch.nn.Sequential(torch.nn.Linear(64, 64), torch.nn.Tanh(), torch.nn.Linear(64, 8))
loss = net(torch.randn(32, 64)).square().mean()
loss.backward()
start = time.perf_counter()
kind = Adam if sys.argv[1] == "maopg" else torch.optim.Adam
optimizer = kind(net.parameters(), lr=5e-4, eps=1e-5)
optimizer.step()
print(time.perf_counter() - start)
"""
"""The timed part: building the optimiser and its first step, after the imports."""


def summary(times: list[float]) -> str:
    return f"{statistics.median(times):.3f} ({min(times):.3f}–{max(times):.3f})"


def verdict(on: list[float], off: list[float], what: str) -> str:
    """``on`` is the optimisation's times, ``off`` without it."""
    ratio = statistics.median(off) / statistics.median(on)
    if min(on) <= max(off) and min(off) <= max(on):
        return f"noise (ranges overlap; {ratio:.2f}×)"
    better = "pays" if ratio > 1 else "costs"
    return f"**{what} {better}: {ratio:.2f}×**"


def alternate(rounds: int, ways: dict[str, Callable[[], float]]) -> dict[str, list[float]]:
    """Each way's seconds over ``rounds`` rounds, the order swapped every round."""
    times: dict[str, list[float]] = {name: [] for name in ways}
    names = list(ways)
    for round_ in range(rounds):
        for name in names if round_ % 2 == 0 else names[::-1]:
            times[name].append(ways[name]())
    return times


def critic_thread(task: str, fields: dict, rounds: int) -> tuple[dict, int, bool]:
    """Seconds of one update, threaded and not; the batch's decision points (rows ×
    environments); whether both updates gave the same weights."""
    config = TrainConfig(task=task, method="async", **fields).resolved()
    torch.set_num_threads(config.torch_threads)
    envs = SeededVectorEnv(
        config.env(),
        num_envs=config.num_envs,
        seed=0,
        backend=config.backend,  # type: ignore[arg-type]
        num_workers=config.num_workers,
        backend_options=config.backend_options(),
    )
    try:
        envs.reset()
        gens = torch.Generator().manual_seed(0), torch.Generator().manual_seed(1)
        learner = build_learner(config, envs.spec, *gens)
        assert isinstance(learner, MAPPOLearner)
        rollout = learner.collect(envs)
    finally:
        envs.close()
    advantages, returns, _ = rollout.advantages(
        learner.value_norm,
        gamma=config.gamma,
        lam=config.learner.gae_lambda,
        form=config.learner.discount,
    )
    batch = rollout.training_batch(advantages, returns)
    start_state = copy.deepcopy(learner.state_dict())
    weights: dict[str, dict] = {}

    def update(threaded: bool) -> Callable[[], float]:
        def run() -> float:
            learner.load_state_dict(copy.deepcopy(start_state))
            learner.ppo.overlap_critic = threaded
            start = time.perf_counter()
            learner.ppo.update(batch, torch.Generator().manual_seed(1))
            seconds = time.perf_counter() - start
            weights["on" if threaded else "off"] = copy.deepcopy(learner.final_state())
            return seconds

        return run

    updating = alternate(rounds, {"on": update(True), "off": update(False)})
    same = all(
        torch.equal(weights["on"][net][name], tensor)
        for net in ("policy", "critic")
        for name, tensor in weights["off"][net].items()
    )
    return updating, rollout.num_steps * rollout.num_envs, same


def first_step(rounds: int) -> dict[str, list[float]]:
    """Seconds of building an optimiser and its first step in a fresh process, each way."""

    def way(kind: str) -> Callable[[], float]:
        def run() -> float:
            command = [sys.executable, "-c", FIRST_STEP, kind]
            out = subprocess.run(command, capture_output=True, text=True, check=True)
            return float(out.stdout)

        return run

    way("maopg")()  # compile the .pyc files once, for both sides
    return alternate(rounds, {"maopg": way("maopg"), "torch": way("torch")})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--cases", default=",".join(CASES), help="comma-separated, of " + ", ".join(CASES)
    )
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    cases = args.cases.split(",")
    unknown = sorted(set(cases) - set(CASES))
    if unknown:
        parser.error(f"unknown case(s) {unknown}; known: {', '.join(CASES)}")
    conditions = markdown()
    began = time.perf_counter()
    rows = []
    for case in cases:
        task, fields = CASES[case]
        print(f"[{case}] ...", file=sys.stderr)
        updating, points, same = critic_thread(task, fields, args.rounds)
        rows.append((case, "PPO update", updating, points, "yes" if same else "**NO**"))
    adam = first_step(args.rounds)
    print("### The learner's plumbing, on and off (`bench/perf/learner_plumbing.py`)\n")
    print(conditions)
    print(
        f"- {args.rounds} rounds, the two ways alternating (order swapped every round); "
        f"median (min–max) seconds; each case at its run's `torch_threads`; total "
        f"{(time.perf_counter() - began) / 60:.1f} min\n"
    )
    print(
        "| case | what | decision points | critic on its thread (s) | one after the other (s) "
        "| verdict | same weights |"
    )
    print("|---|---|---|---|---|---|---|")
    for case, what, times, points, same in rows:
        print(
            f"| {case} | {what} | {points:,} | {summary(times['on'])} | {summary(times['off'])} "
            f"| {verdict(times['on'], times['off'], 'the thread')} | {same} |"
        )
    print("\n| what | maopg's Adam (s) | `torch.optim.Adam` (s) | verdict |")
    print("|---|---|---|---|")
    print(
        f"| build + first step in a fresh process | {summary(adam['maopg'])} | "
        f"{summary(adam['torch'])} | {verdict(adam['maopg'], adam['torch'], 'maopg Adam')} |"
    )


if __name__ == "__main__":
    main()

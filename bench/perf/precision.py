"""What ``precision=bf16`` saves: the CNN alone, and the PPO update on a real Water Filling batch.

Run: ``.venv/bin/python bench/perf/precision.py [--run runs/bench/train_speed_wf_bf16]
[--rounds 3]``.
Prints a Markdown block for BENCHMARKS.md.

1. The NatureCNN of the encoders, forward and backward over ``--images`` 64 px images (the
   distinct images of a late Water Filling batch number about that many), ``fp32`` against
   ``bf16``.
2. One PPO update (the default 10 epochs, actor and critic) of `async` from RGB on one batch of
   Water Filling's 2,000 ticks, collected once by the policy and critic of ``--run``'s
   checkpoint (a run of `async` from RGB at the default settings, as
   ``bench/perf/train_speed_wf.py`` trains) (a trained policy decides more often, so its batch
   holds more decision points and images than an untrained one's; without ``--run``, the
   untrained networks). Both precisions start from the same weights and optimiser state and
   update on the same batch, so the table also shows how far their losses move apart.

The precisions alternate within each of ``--rounds`` rounds, so a change in the machine's load
hits both alike; figures are medians. The conditions list whether this CPU has bf16
instructions: without them oneDNN emulates bf16 and ``bf16`` is slower.
"""

from __future__ import annotations

import argparse
import copy
import statistics
import time
from pathlib import Path

import numpy as np
import torch

from maopg.env.vector import SeededVectorEnv
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import CHECKPOINT
from maopg.experiment.run.sysinfo import markdown
from maopg.experiment.training.trainer import build_learner
from maopg.learner import MAPPOLearner, load_checkpoint
from maopg.policy import PRECISIONS, NatureCNN, set_precision


def cnn_seconds(images: int, rounds: int) -> dict[str, float]:
    """Median seconds of a NatureCNN forward + backward over ``images`` random images."""
    torch.manual_seed(0)
    cnn = NatureCNN((64, 64, 3))
    batch = torch.randint(0, 256, (images, 64, 64, 3), dtype=torch.uint8)
    times: dict[str, list[float]] = {p: [] for p in PRECISIONS}
    for round_ in range(rounds + 1):  # the first round warms oneDNN's kernels up
        for precision in PRECISIONS:
            set_precision(cnn, precision)
            cnn.zero_grad()
            start = time.perf_counter()
            cnn(batch).sum().backward()
            if round_:
                times[precision].append(time.perf_counter() - start)
    return {p: statistics.median(t) for p, t in times.items()}


def update_seconds(
    run: Path | None, rounds: int
) -> tuple[dict[str, float], dict[str, dict[str, float]], int, int]:
    """Median seconds of one PPO update per precision on one collected batch; the first
    round's stats per precision; the batch's decision points and distinct images."""
    config = TrainConfig(task="water_filling", method="async", images=True).resolved()
    envs = SeededVectorEnv(config.env(), num_envs=config.num_envs, seed=0, backend="local")
    try:
        envs.reset()
        gens = torch.Generator().manual_seed(0), torch.Generator().manual_seed(1)
        learner = build_learner(config, envs.spec, *gens)
        assert isinstance(learner, MAPPOLearner)
        if run is not None:
            learner.load_state_dict(load_checkpoint(run / CHECKPOINT))
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
    times: dict[str, list[float]] = {p: [] for p in PRECISIONS}
    stats: dict[str, dict[str, float]] = {}
    for _ in range(rounds):
        for precision in PRECISIONS:
            learner.load_state_dict(copy.deepcopy(start_state))
            set_precision(learner.policy, precision)
            set_precision(learner.critic, precision)
            start = time.perf_counter()
            row = learner.ppo.update(batch, torch.Generator().manual_seed(1))
            times[precision].append(time.perf_counter() - start)
            stats.setdefault(precision, row)
    images = batch.obs.images  # each camera image of the batch, or its bank of distinct ones
    distinct = len(np.unique(images.flatten(end_dim=-4).flatten(1).numpy(), axis=0))
    medians = {p: statistics.median(t) for p, t in times.items()}
    return medians, stats, rollout.num_steps * rollout.num_envs, distinct


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--run", type=Path, help="a Water Filling async RGB run directory")
    parser.add_argument("--images", type=int, default=1500)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--torch-threads",
        type=int,
        default=TrainConfig.torch_threads,
        help="torch.set_num_threads, as a run's torch_threads (default %(default)s, its default)",
    )
    args = parser.parse_args()
    torch.set_num_threads(args.torch_threads)
    conditions = markdown()
    cnn = cnn_seconds(args.images, args.rounds)
    update, stats, points, distinct = update_seconds(args.run, args.rounds)
    print("### `precision=bf16` against `fp32` (`bench/perf/precision.py`)\n")
    print(conditions)
    networks = f"the checkpoint of `{args.run}`" if args.run else "untrained networks"
    print(
        f"- {args.rounds} rounds, precisions alternating; one Water Filling `async` RGB batch "
        f"({points:,} decision points, {distinct:,} distinct camera images) collected by "
        f"{networks}\n"
    )
    print("| what | fp32 (s) | bf16 (s) | fp32 / bf16 |")
    print("|---|---|---|---|")
    print(
        f"| NatureCNN forward + backward, {args.images:,} images | {cnn['fp32']:.3f} | "
        f"{cnn['bf16']:.3f} | {cnn['fp32'] / cnn['bf16']:.2f}× |"
    )
    print(
        f"| PPO update (10 epochs, actor and critic) | {update['fp32']:.2f} | "
        f"{update['bf16']:.2f} | {update['fp32'] / update['bf16']:.2f}× |"
    )
    keys = ("policy_loss", "value_loss", "entropy", "approx_kl")
    print("\nThe update's statistics from the same weights and batch:\n")
    print(f"| precision | {' | '.join(keys)} |")
    print("|---|" + "---|" * len(keys))
    for precision in PRECISIONS:
        print(f"| {precision} | " + " | ".join(f"{stats[precision][k]:.5g}" for k in keys) + " |")


if __name__ == "__main__":
    main()

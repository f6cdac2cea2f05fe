"""Does a training curve lag its policy, or does collection play worse than evaluation?

Run: ``.venv/bin/python bench/analysis/frozen_collection.py RUN_DIR [RUN_DIR ...]
[--iterations 15]``

A run's curve is the mean return of the episodes that ended in each iteration, played by the
sampled policy of that iteration inside training's collection: vector environments whose
episodes run on across iterations, recurrent states carried from one iteration to the next.
``python -m eval evaluate --sample`` plays the final policy from fresh episodes, one at a time.
Where the two disagree (the ``memory`` study's recurrent ``async``: curves ending near
−3.3×10⁵, final policies sampled over the evaluation's 100 episodes at −3.0 to −3.2×10⁵),
either the policies of the last iterations were worse than the final one, collection itself
plays worse, or the episodes drawn differ.

This separates them: it loads each run's final policy into the learner the run trained with
and collects ``--iterations`` batches from freshly reset environments (``--seed``, other
episodes than the run's own) with the policy frozen: no update between them. It prints the
mean return of the episodes that ended (± its standard error) beside the curve's last 10% and
its final iteration, so the final policy is read in training's own collection, over more
episodes than the curve's last 10% holds.
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

import torch

from maopg.env.vector import SeededVectorEnv
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import CONFIG, FINAL
from maopg.experiment.run.migration import read_checkpoint
from maopg.experiment.run.sysinfo import markdown
from maopg.experiment.studies.runs import RETURN, final, load_run
from maopg.experiment.training.trainer import build_learner


def curve_tail(run_dir: Path) -> tuple[float, float]:
    """The curve's final return (its last 10% of samples, as the tables) and last iteration's."""
    run = load_run(run_dir)
    return final(run), float(run.curve(RETURN)[1][-1])


def frozen_returns(run_dir: Path, iterations: int, seed: int) -> list[float]:
    """Episode returns of ``iterations`` batches collected by the run's final policy, frozen."""
    config = TrainConfig.load(run_dir / CONFIG).resolved()
    torch.set_num_threads(config.torch_threads or 1)
    state = read_checkpoint(run_dir / FINAL, required=("policy", "critic"))
    envs = SeededVectorEnv(config.env(), num_envs=config.num_envs, seed=seed, backend="local")
    try:
        sample_gen = torch.Generator().manual_seed(seed)
        learner = build_learner(config, envs.spec, sample_gen, torch.Generator())
        learner.policy.load_state_dict(state["policy"])
        learner.critic.load_state_dict(state["critic"])  # collection values every point
        envs.reset()
        returns: list[float] = []
        for _ in range(iterations):
            returns += [episode["return"] for episode in learner.collect(envs).episodes]
        return returns
    finally:
        envs.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="MAPPO run directories with final.pt")
    parser.add_argument("--iterations", type=int, default=15)
    parser.add_argument("--seed", type=int, default=1000, help="the environments' reset seed")
    args = parser.parse_args()
    print(markdown())
    print(f"- each run's environments reset with seed {args.seed}, the policy sampled, no update\n")
    print(
        "| run | curve: last 10% | curve: last iteration "
        f"| final policy frozen, {args.iterations} iterations | episodes |"
    )
    print("|---|---|---|---|---|")
    for run_dir in args.runs:
        tail, last = curve_tail(run_dir)
        returns = frozen_returns(run_dir, args.iterations, args.seed)
        mean, n = statistics.fmean(returns), len(returns)
        error = statistics.stdev(returns) / n**0.5
        print(f"| {run_dir} | {tail:,.0f} | {last:,.0f} | {mean:,.0f} ± {error:,.0f} | {n} |")


if __name__ == "__main__":
    main()

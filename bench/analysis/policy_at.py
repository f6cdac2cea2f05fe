"""What a committed run's policy did at a point of its curve, where the run kept no weights.

A run keeps its final weights only, but training is deterministic per seed on one machine: this
trains the run's saved ``config.json`` afresh to ``--samples`` (into ``--out``; a rerun reuses
what is there), then plays ``--episodes`` sampled episodes of that policy (as evaluations during
training act: no ε; reset seeds 0, 1, ...) and prints each one's return and ticks and every
agent's choices in order, repeats folded (``Push ×95``): what a dip in an evaluation curve was.
The retrained curve is checked row for row against the committed one up to ``--samples`` (the
machine's timings aside); a mismatch is printed, as the policy is then not the run's.

Run: ``.venv/bin/python bench/analysis/policy_at.py RUN_DIR --samples N [--episodes 3]
[--out DIR]``.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
from itertools import groupby
from pathlib import Path

import numpy as np

from maopg.env.rollout import run_episode
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import CONFIG, FINAL, METRICS, TIMING_COLUMNS
from maopg.experiment.training.trainer import train


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open() as handle:
        return [
            {k: v for k, v in row.items() if k not in TIMING_COLUMNS}
            for row in csv.DictReader(handle)
        ]


def folded(names: list[str]) -> str:
    """``a, a, a, b`` → ``a ×3, b``."""
    parts = []
    for name, run in groupby(names):
        count = len(list(run))
        parts.append(name if count == 1 else f"{name} ×{count}")
    return ", ".join(parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run", type=Path, help="a run directory with its config.json")
    parser.add_argument("--samples", type=int, required=True, help="where on the curve")
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("/tmp/policy_at"))
    args = parser.parse_args()
    config = TrainConfig.load(args.run / CONFIG)
    out = args.out / f"{config.task}-{config.method}-seed{config.seed}-{args.samples}"
    if not (out / FINAL).exists():
        train(
            dataclasses.replace(
                config, total_samples=args.samples, run_dir=str(out), plot=False, progress=False
            )
        )
    mine, theirs = _rows(out / METRICS), _rows(args.run / METRICS)
    same = mine[:-1] == theirs[: len(mine) - 1]
    print(
        f"{args.run} retrained to {mine[-1]['samples']} samples: "
        + ("its curve row for row" if same else "NOT its curve (the policy below is another)")
    )
    trained = load_trained(out / FINAL)
    env = trained.make_env(0)
    actor = trained.actor(greedy=False, seed=0)
    agents = env.spec.agents
    try:
        for episode in range(args.episodes):
            chosen: list[list[str]] = [[] for _ in agents]

            def policy(point, chosen=chosen):
                joint = np.asarray(actor(point))
                for i in np.flatnonzero(point.choosing):
                    chosen[i].append(agents[i].option_names[joint[i]])
                return joint

            result = run_episode(env, policy, seed=episode)
            print(f"\nepisode {episode}: return {result.ret:.1f}, {result.ticks} ticks")
            for agent, names in zip(agents, chosen, strict=True):
                print(f"- {agent.name}: {folded(names)}")
    finally:
        env.close()


if __name__ == "__main__":
    main()
